"""Ending a ROS process that has shut down in order, without the interpreter's finalization.

A node process of the suite stops in order (:func:`tensegrity_ros.nodes.common.spin_node`):
its threads are joined, the executor shut down, the nodes destroyed, the context shut down,
bags closed. What would come next, CPython's finalization, is where the native aborts of a
ROS 2 Python process at exit come from (rclpy 7.1.6 over pybind11, Fast DDS 2.14):

- a Python thread still inside an rclpy call that released the GIL (any library's thread,
  or one of ours that a bug left running) is ended with ``pthread_exit`` when it asks for
  the GIL back; the forced unwind through pybind11's ``noexcept`` ``gil_scoped_release``
  destructor calls ``std::terminate`` ("terminate called without an active exception",
  SIGABRT; :mod:`tensegrity_ros.rclpy_utils.spin_thread` has the stack);
- module teardown and the garbage collector then destroy rclpy objects in no particular
  order after their context, and ``exit()`` runs the C++ static destructors of Fast DDS and
  the logging libraries while their own threads may still run.

Nothing in that phase is needed once the process has stopped in order, so
:func:`end_process` flushes what Python buffers (the logging module's handlers, stdout and
stderr) and ends the process with ``os._exit``: the threads end with it, in the kernel,
without unwinding, and no destructor runs. Atexit handlers do not run either; the suite's
processes register none that matter once their nodes are destroyed (logging is flushed
here; the form-finding node's worker processes are killed by the node itself, and its
forkserver ends when this process does).
"""

from __future__ import annotations

import contextlib
import logging
import os
import sys
from typing import NoReturn


def end_process(code: int) -> NoReturn:
    """Flush logging, stdout and stderr, then end the process with exit status ``code`` at
    once (``os._exit``: no finalization, no atexit handlers, no C++ static destructors)."""
    logging.shutdown()
    for stream in (sys.stdout, sys.stderr):
        with contextlib.suppress(Exception):      # a closed or broken stream: nothing to keep
            stream.flush()
    os._exit(code)
