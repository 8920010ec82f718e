"""ODN, the paper's object depth network (Griffin & Corso, ECCV 2020, section 4), and its recipe.

`variants` names the three networks (what each learns and which distances it sees), torch-free;
`odn` is the architecture; `run_folder` the files of a training run; `training` the paper's
recipe on the generated stream; `prediction` a trained network over stores; `runtime` what those
two share (the device, a store's batches, the forward pass, checkpoints read). Everything but
`variants` needs PyTorch (the `torch` extra). See docs/TRAINING.md.
"""
