"""Learned modules in plain torch (the optional extra ``pip install fallgen[learn]``).

- :mod:`fallgen.learn.runtime`: the device (``cpu`` by default, ``cuda`` when asked and
  present), deterministic runs (seeded generators, ``torch.use_deterministic_algorithms``
  while a job runs, a fixed thread count), the allocator setting that keeps a CPU training
  loop from page-faulting;
- :mod:`fallgen.learn.nets`: a small encoder-decoder for semantic segmentation (:class:`SegNet`);
- :mod:`fallgen.learn.frames`: training and test frames of a build: each episode's step-0 view
  (the dataset's own arrays) and views rendered along its expert's path, kept on disk;
- :mod:`fallgen.learn.vision_model`: the visual perception module (segmentation of the 31
  target categories from RGB-D), trained on a build's train split;
- :mod:`fallgen.learn.vision_eval`: its scores on a split (IoU per category, the fallen object
  found, false alarms) and its pictures.

Nothing here is imported by the rest of fallgen unless a learned module is asked for, so the
package works without torch.
"""

from __future__ import annotations


def require_torch():
    """The torch module, or ImportError saying how to install it."""
    try:
        import torch
    except ImportError:
        raise ImportError("the learned modules need torch: pip install 'fallgen[learn]'") \
            from None
    return torch


__all__ = ["require_torch"]
