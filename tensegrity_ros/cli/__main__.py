from tensegrity_ros.cli import run

run()
