# Runs inside Debian's Blender (its Python has numpy and reads OpenEXR):
#   blender -b --factory-startup --python disk_mean.py -- RADIUS IMAGE.exr [IMAGE.exr ...]
# Prints each image's mean RGB over the centred disk of RADIUS (a fraction of half the image's
# height): the sphere of scripts/bench_plastic_furnace.sh, whose pixels read its albedo.
import json
import sys

import bpy
import numpy as np

args = sys.argv[sys.argv.index("--") + 1:]
radius = float(args[0])
out = {}
for path in args[1:]:
    img = bpy.data.images.load(path, check_existing=False)
    img.colorspace_settings.name = "Non-Color"
    w, h = img.size
    px = np.empty(w * h * 4, dtype=np.float32)
    img.pixels.foreach_get(px)
    rgb = px.reshape(h, w, 4)[:, :, :3].astype(np.float64)
    y, x = np.mgrid[0:h, 0:w]
    r = np.hypot(x + 0.5 - w / 2, y + 0.5 - h / 2) / (h / 2)
    out[path] = [float(v) for v in rgb[r < radius].mean(axis=0)]
print("DISK_MEAN_JSON " + json.dumps(out), flush=True)
