"""Train a small object depth network (after the paper's ODN) in JAX on freshly generated examples fed
by grain, then write a predictions CSV for a store that `odms-data score` scores.

    python examples/train_odn_jax.py --store sim-val.zarr --out predictions.csv

A small stand-in for ODN that shows the grain loader (the paper's ODN itself, in PyTorch, is
`odms-data train`). The network sees the 112x112 masks of the n observations plus the radial image
as channels, and the normalised camera positions zbar beside its pooled features; it predicts the
relative scale d1/d_n in (0, 1), from which d1 = s (z_n - z_1) / (1 - s). Needs
pip install 'odms-data[jax]' (jax, grain, optax).
"""

from __future__ import annotations

import argparse
import time

import grain
import jax
import jax.numpy as jnp
import numpy as np
import optax

from odms_data.evaluation.predictions import write_predictions
from odms_data.loaders import Transform
from odms_data.loaders.grain_loader import StoreSource, stream_dataset
from odms_data.simulate.params import GeneratorParams
from odms_data.store.reader import open_store

WIDTHS = (16, 32, 64, 64)


def init(key: jax.Array, n_obs: int) -> dict:
    """He-initialised weights: 4 strided 3x3 convolutions, then two dense layers."""
    params: dict = {"conv": [], "dense": []}
    c = n_obs + 1
    for width in WIDTHS:
        key, k = jax.random.split(key)
        w = jax.random.normal(k, (width, c, 3, 3)) * jnp.sqrt(2 / (9 * c))
        params["conv"].append((w, jnp.zeros((width, 1, 1))))
        c = width
    for n_in, n_out in ((c + n_obs - 2, 64), (64, 1)):
        key, k = jax.random.split(key)
        params["dense"].append((jax.random.normal(k, (n_in, n_out)) * jnp.sqrt(2 / n_in), jnp.zeros(n_out)))
    return params


def scale(params: dict, masks: jax.Array, radial: jax.Array, zbar: jax.Array) -> jax.Array:
    """The predicted relative scale d1/d_n of each example of a batch."""
    x = jnp.concatenate([masks.astype(jnp.float32), radial], axis=1)  # float32 unless rounded=True
    for w, b in params["conv"]:
        x = jax.lax.conv_general_dilated(x, w, (2, 2), "SAME", dimension_numbers=("NCHW", "OIHW", "NCHW"))
        x = jax.nn.relu(x + b)
    x = jnp.concatenate([x.mean(axis=(2, 3)), zbar], axis=1)
    (w1, b1), (w2, b2) = params["dense"]
    return jax.nn.sigmoid(jax.nn.relu(x @ w1 + b1) @ w2 + b2)[:, 0]


def loss(params: dict, batch: dict) -> jax.Array:
    return jnp.abs(scale(params, batch["masks"], batch["radial"], batch["zbar"]) - batch["scale"]).mean()


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--store", help="store to predict (e.g. sim-val.zarr); omit to only train")
    ap.add_argument("--out", default="predictions.csv", help="predictions CSV (split,example_id,d1)")
    ap.add_argument("--steps", type=int, default=300)
    ap.add_argument("--batch-size", type=int, default=64)
    ap.add_argument("--threads", type=int, default=2, help="grain threads drawing batches")
    ap.add_argument("--seed", type=int, default=0, help="generator seed (the splits use 2020000x)")
    ap.add_argument("--n-obs", type=int, default=10)
    ap.add_argument("--lr", type=float, default=2e-3)
    args = ap.parse_args(argv)

    transform = Transform(n_obs=args.n_obs, radial=True)
    train = stream_dataset(args.batch_size, args.steps, params=GeneratorParams(n_obs=args.n_obs),
                           seed=args.seed, transform=transform)
    params = init(jax.random.key(args.seed), args.n_obs)
    opt = optax.adam(optax.cosine_onecycle_schedule(args.steps, args.lr))
    state = opt.init(params)

    @jax.jit
    def step(params, state, batch):
        value, grads = jax.value_and_grad(loss)(params, batch)
        updates, state = opt.update(grads, state)
        return optax.apply_updates(params, updates), state, value

    keys = ("masks", "radial", "zbar", "scale")
    # the drawing releases the GIL: threads draw batches in parallel, a few batches ahead
    threads = grain.ReadOptions(num_threads=args.threads, prefetch_buffer_size=args.threads)
    batches = iter(train.to_iter_dataset(threads))
    t0 = time.perf_counter()
    for i, batch in enumerate(batches, 1):
        params, state, value = step(params, state, {k: jax.device_put(batch[k]) for k in keys})
        if i % 50 == 0 or i == args.steps:
            print(f"step {i}/{args.steps}  L1(scale) {float(value):.4f}  {time.perf_counter() - t0:.0f} s",
                  flush=True)
    batches.close()
    if not args.store:
        return

    with open_store(args.store) as store:
        split, ids, true_d1 = store.attrs.split, store.example_ids, store.d1
    predict = jax.jit(scale)
    rows, errors = [], []
    for batch in grain.MapDataset.source(StoreSource(args.store, transform)).batch(256):
        s = np.minimum(np.asarray(predict(params, batch["masks"], batch["radial"], batch["zbar"])), 0.999)
        d1 = s * batch["dz"][:, -1] / (1 - s)
        for i, d in zip(batch["index"].tolist(), d1.tolist(), strict=True):
            rows.append((split, ids[i], d))
            errors.append(abs(d - true_d1[i]) / true_d1[i])
    write_predictions(args.out, rows)
    labelled = [e for e in errors if e == e]
    if labelled:
        mean = 100 * sum(labelled) / len(labelled)
        print(f"mean |d1 error| / d1 on {len(labelled)} labelled examples: {mean:.1f}%")
    print(f"wrote {args.out} ({len(rows)} rows); score it with `odms-data score`")


if __name__ == "__main__":
    main()
