// The page's resolution follows its frame rate: tensegrity_ros/view/resolution.py says why and how.
// Called with the view's configuration ({target, scales, windowMs, busy, idleFps}) once per page.
(config) => {
  if (window.__tensegrityResolution) return;                       // a reconnected page: already running
  const state = { scale: 1.0, dpr: null, mode: "starting", changes: 0 };
  window.__tensegrityResolution = state;
  if (new URLSearchParams(window.location.search).has("fixedDpr")) {
    state.mode = "fixed in the URL";                               // the user's choice: left alone
    return;
  }
  let viser = null;            // viser's page hooks: renderer statistics, dev settings
  let ticks = 0, frames = 0, windowStart = 0, settle = 0;

  function apply(scale, now) {
    state.scale = scale;
    state.dpr = window.devicePixelRatio * scale;
    state.changes += 1;
    viser.devSettings.set({ fixedDpr: state.dpr });              // viser's "Device Pixel Ratio"
    if (window.__viserMutable && window.__viserMutable.requestRender) window.__viserMutable.requestRender();
    windowStart = now;
    ticks = 0;
    frames = viser.rendererInfo.render.frame;
    settle = 1;                                                    // the window after a change does not count
  }

  function tick(now) {
    requestAnimationFrame(tick);
    if (viser === null) {
      if (!window.__viserTestpoints) return;                       // the canvas is not mounted yet
      viser = window.__viserTestpoints;
      state.mode = "adaptive";
      apply(1.0, now);
      return;
    }
    if (state.mode !== "adaptive") return;
    if (viser.devSettings.get().fixedDpr !== state.dpr) {          // set by the user in Dev Settings
      state.mode = "set by the user";
      return;
    }
    ticks += 1;
    const frame = viser.rendererInfo.render.frame;                 // renders so far (three.js)
    const seconds = (now - windowStart) / 1000;
    if (seconds * 1000 < config.windowMs) return;
    const rendered = frame - frames;
    const fps = rendered / seconds;
    state.fps = fps;
    // Slow: fewer frames than the view sends, the page drawing in nearly every animation frame.
    const slow = fps < config.target && rendered >= config.busy * ticks;
    // Idle: a few renders a second in an otherwise quiet page (paused, a bag at its end).
    const idle = fps < config.idleFps && rendered < config.busy * ticks;
    const lower = config.scales.find((s) => s < state.scale);
    if (idle && state.scale !== 1.0) {
      apply(1.0, now);
      return;
    }
    if (settle > 0) settle -= 1;
    else if (slow && lower !== undefined) {
      apply(lower, now);
      return;
    }
    windowStart = now;
    ticks = 0;
    frames = frame;
  }
  requestAnimationFrame(tick);
}
