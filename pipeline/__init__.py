"""The offline build pipeline: models, transcriptions, solvers, sweeps and the command line."""
