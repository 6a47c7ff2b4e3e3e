# Runs inside Debian's Blender (its Python has numpy and reads OpenEXR):
#   blender -b --factory-startup --python rel_mse.py -- REFERENCE.exr IMAGE.exr [IMAGE.exr ...]
# Prints one JSON object: each image's relative MSE against the reference, Tessera's measure
# (mean over pixels and RGB channels of (x - r)^2 / (r^2 + 0.01)), and each image's mean.
import json
import sys

import bpy
import numpy as np


def rgb(path):
    img = bpy.data.images.load(path, check_existing=False)
    img.colorspace_settings.name = "Non-Color"  # the EXR's values as stored: linear, untouched
    w, h = img.size
    px = np.empty(w * h * 4, dtype=np.float32)
    img.pixels.foreach_get(px)
    bpy.data.images.remove(img)
    return px.reshape(h, w, 4)[:, :, :3].astype(np.float64)


args = sys.argv[sys.argv.index("--") + 1:]
ref = rgb(args[0])
out = {"reference": args[0], "reference_mean": float(ref.mean()), "images": {}}
for path in args[1:]:
    x = rgb(path)
    if x.shape != ref.shape:
        sys.exit(f"rel_mse: {path} is {x.shape[1]}x{x.shape[0]}, the reference {ref.shape[1]}x{ref.shape[0]}")
    out["images"][path] = {"rel_mse": float(np.mean((x - ref) ** 2 / (ref ** 2 + 0.01))), "mean": float(x.mean())}
print("REL_MSE_JSON " + json.dumps(out), flush=True)
