"""Many runs at once: suites, sweeps, the regression gate, replays, the demo, MOT-file tracking."""
