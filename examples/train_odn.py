"""Train a small object depth network (after the paper's ODN) on freshly generated examples, then
write a predictions CSV for a store that `odms-data score` scores.

    python examples/train_odn.py --store sim-val.zarr --out predictions.csv

The network sees the 112x112 masks of the n observations plus the radial image as channels, and
the normalised camera positions zbar beside its pooled features; it predicts the relative scale
d1/d_n in (0, 1), from which d1 = s (z_n - z_1) / (1 - s). A few hundred steps take minutes on a
CPU; a GPU is used when there is one.
"""

from __future__ import annotations

import argparse
import csv
import time

import torch
from torch import nn
from torch.utils.data import DataLoader

from odms_data.loaders import Transform
from odms_data.loaders.torch_loader import StoreDataset, StreamDataset
from odms_data.simulate.params import GeneratorParams
from odms_data.store.reader import open_store


class ODN(nn.Module):
    def __init__(self, n_obs: int) -> None:
        super().__init__()
        layers, c = [], n_obs + 1
        for width in (16, 32, 64, 64):
            layers += [nn.Conv2d(c, width, 3, stride=2, padding=1), nn.BatchNorm2d(width), nn.ReLU()]
            c = width
        self.features = nn.Sequential(*layers, nn.AdaptiveAvgPool2d(1), nn.Flatten())
        self.head = nn.Sequential(nn.Linear(c + n_obs - 2, 64), nn.ReLU(), nn.Linear(64, 1), nn.Sigmoid())

    def forward(self, masks: torch.Tensor, radial: torch.Tensor, zbar: torch.Tensor) -> torch.Tensor:
        x = self.features(torch.cat([masks.float(), radial], dim=1))
        return self.head(torch.cat([x, zbar], dim=1)).squeeze(1)


def predict_d1(model: ODN, batch: dict, device: torch.device) -> torch.Tensor:
    b = {k: v.to(device, non_blocking=True) for k, v in batch.items()}
    s = model(b["masks"], b["radial"], b["zbar"]).clamp(max=0.999)
    return s * b["dz"][:, -1] / (1 - s)


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--store", help="store to predict (e.g. sim-val.zarr); omit to only train")
    ap.add_argument("--out", default="predictions.csv", help="predictions CSV (split,example_id,d1)")
    ap.add_argument("--steps", type=int, default=300)
    ap.add_argument("--batch-size", type=int, default=64)
    ap.add_argument("--workers", type=int, default=2, help="DataLoader worker processes")
    ap.add_argument("--seed", type=int, default=0, help="generator seed (the splits use 2020000x)")
    ap.add_argument("--n-obs", type=int, default=10)
    ap.add_argument("--lr", type=float, default=2e-3)
    args = ap.parse_args(argv)

    device = torch.device("cuda" if torch.cuda.is_available() else "cpu")
    torch.manual_seed(args.seed)
    transform = Transform(n_obs=args.n_obs, radial=True)
    train = StreamDataset(args.batch_size, args.steps, params=GeneratorParams(n_obs=args.n_obs),
                          seed=args.seed, transform=transform)
    loader = DataLoader(train, batch_size=None, num_workers=args.workers,
                        pin_memory=device.type == "cuda")
    model = ODN(args.n_obs).to(device)
    opt = torch.optim.Adam(model.parameters(), lr=args.lr)
    sched = torch.optim.lr_scheduler.OneCycleLR(opt, args.lr, total_steps=args.steps)
    t0 = time.perf_counter()
    model.train()
    for step, batch in enumerate(loader, 1):
        b = {k: v.to(device, non_blocking=True) for k, v in batch.items()}
        loss = (model(b["masks"], b["radial"], b["zbar"]) - b["scale"]).abs().mean()
        opt.zero_grad()
        loss.backward()
        opt.step()
        sched.step()
        if step % 50 == 0 or step == args.steps:
            print(f"step {step}/{args.steps}  L1(scale) {loss.item():.4f}  {time.perf_counter() - t0:.0f} s",
                  flush=True)
    if not args.store:
        return

    model.eval()
    with open_store(args.store) as store:
        split, ids, true_d1 = store.attrs.split, store.example_ids, store.d1
    eval_loader = DataLoader(StoreDataset(args.store, transform), batch_size=256, num_workers=args.workers)
    rows, errors = [], []
    with torch.no_grad():
        for batch in eval_loader:
            d1 = predict_d1(model, batch, device).cpu().tolist()
            for i, d in zip(batch["index"].tolist(), d1, strict=True):
                rows.append((split, ids[i], d))
                errors.append(abs(d - true_d1[i]) / true_d1[i])
    with open(args.out, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["split", "example_id", "d1"])
        w.writerows((s, e, f"{d:.6f}") for s, e, d in rows)
    labelled = [e for e in errors if e == e]
    if labelled:
        mean = 100 * sum(labelled) / len(labelled)
        print(f"mean |d1 error| / d1 on {len(labelled)} labelled examples: {mean:.1f}%")
    print(f"wrote {args.out} ({len(rows)} rows); score it with `odms-data score`")


if __name__ == "__main__":
    main()
