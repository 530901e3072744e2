"""The Raven-II surgical robot: the deviation monitor's models, the arm's kinematics and dynamics,
fault-injection campaigns (`campaign/`) and certified FMT* planning (`plan/`)."""
