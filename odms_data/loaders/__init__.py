"""Loaders of ODMS examples for training: from a store or straight from the generator.

`transforms` makes the paper's network inputs (`box_transform` DBox's, from box examples);
`sources` gives examples as dicts of NumPy arrays; `numpy_loader` batches them with no
framework; `grain_loader`, `torch_loader` and `tf_loader` wrap them for grain (JAX), PyTorch and
TensorFlow and are imported only when asked for (named so that none shadows its framework's
package). See docs/LOADERS.md.
"""

from .box_transform import DBOX_TRANSFORM, BoxTransform
from .numpy_loader import Batches, store_batches, stream_batches
from .sources import GeneratedExamples, StoreExamples
from .transforms import LABELS, PAPER_SIZE, Transform

__all__ = [
    "DBOX_TRANSFORM", "LABELS", "PAPER_SIZE", "Batches", "BoxTransform", "GeneratedExamples",
    "StoreExamples", "Transform", "store_batches", "stream_batches",
]
