"""What every environment shares, below the engines (`runtime/`, `batch/`, `warp/`): the control loop and its
settings (`control.py`), the model and suite an environment runs (`model.py`), and when an episode ends
(`episode.py`). Nothing here imports an engine; `env/` (the single-simulation `Environment`), `batch/` and
`warp/` (and `mjlab/` on it) build on it."""
