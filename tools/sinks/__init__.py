"""Where a run's records go: the run directory, SQLite, annotated video, rerun, key frames, box drawing."""
