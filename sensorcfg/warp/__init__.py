"""The optional GPU engine (the `warp` extra: `pip install '.[warp]'` in a clone): a suite on nworld MuJoCo Warp worlds.

`philox`: the noise streams' counter-based numbers as Warp functions; `worlds`: the worlds' physics. Neither
is imported here, so that `import sensorcfg.warp` works without Warp installed."""
