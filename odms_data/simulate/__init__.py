"""Simulated data: the paper's object model and everything that turns it into masks and stores.

The random draws of one example (object_model.py), how a contour becomes a silhouette
(raster.py), the reference renderer at any size (render.py), the fast batch renderers that
match it pixel for pixel (batch_render.py, and torch_render.py in PyTorch on any device) and
INTER_AREA shrinking of a mask's box alone (shrink.py); generating a store in shard tasks
(shards.py, generate_store.py), written by the store builder (store/build.py) locally or on a Dask cluster.
"""
