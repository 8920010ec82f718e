"""ODN, the ODMS paper's object depth network (Griffin & Corso, ECCV 2020, section 4), DBox, ODMD's
network on detection boxes (CVPR 2021), and their authors' recipes.

`variants` names the networks (what each learns, which inputs it sees, its recipe), torch-free;
`odn` and `dbox` are the architectures; `models` what training and prediction need of each (the
network, its stream, a store's inputs, the depth an output means); `run_folder` the files of a
training run; `training` the recipe on the generated stream; `prediction` a trained network over
stores; `runtime` what those two share (the device, a store's batches, checkpoints read).
Everything but `variants` needs PyTorch (the `torch` extra). See docs/TRAINING.md.
"""
