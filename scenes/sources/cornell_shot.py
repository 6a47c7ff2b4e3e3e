#!/usr/bin/env python3
"""Writes scenes/cornell_shot.gltf: the Cornell box of cornell_box.gltf with a cube that spins
(LINEAR rotation), bounces (CUBICSPLINE translation), pulses (STEP scale) and bulges (a morph
target with LINEAR weights), and a camera that dollies in (LINEAR translation). Two animations,
"Cube" and "Dolly", two seconds each. Run from the project's root: python3 scenes/sources/cornell_shot.py"""
import base64, json, math, struct

src = json.load(open("scenes/cornell_box.gltf"))
buf = bytearray(base64.b64decode(src["buffers"][0]["uri"].split(",", 1)[1]))

def add(values, fmt, count, type_, comp=5126, minmax=None):
    while len(buf) % 4: buf.append(0)
    off = len(buf)
    buf.extend(struct.pack("<%d%s" % (len(values), fmt), *values))
    src["bufferViews"].append({"buffer": 0, "byteOffset": off, "byteLength": len(buf) - off})
    acc = {"bufferView": len(src["bufferViews"]) - 1, "componentType": comp, "count": count, "type": type_}
    if minmax: acc["min"], acc["max"] = minmax
    src["accessors"].append(acc)
    return len(src["accessors"]) - 1

# A cube of edge 0.4 around the origin: 24 vertices (a normal per face), 36 indices.
h = 0.2
faces = [((1,0,0),(0,1,0),(0,0,1)), ((-1,0,0),(0,1,0),(0,0,-1)), ((0,1,0),(0,0,1),(1,0,0)),
         ((0,-1,0),(0,0,-1),(1,0,0)), ((0,0,1),(1,0,0),(0,1,0)), ((0,0,-1),(-1,0,0),(0,1,0))]
pos, nrm, idx, bulge = [], [], [], []
for n, u, v in faces:
    base = len(pos) // 3
    for su, sv in ((-1,-1),(1,-1),(1,1),(-1,1)):
        p = [h * (n[k] + su * u[k] + sv * v[k]) for k in range(3)]
        pos += p; nrm += list(n)
        bulge += [0.0, 0.15 if p[1] > 0 else 0.0, 0.0]  # the morph target lifts the top
    a, b, c = (u[1]*v[2]-u[2]*v[1], u[2]*v[0]-u[0]*v[2], u[0]*v[1]-u[1]*v[0])
    ccw = a*n[0] + b*n[1] + c*n[2] > 0
    idx += [base, base+1, base+2, base, base+2, base+3] if ccw else [base, base+2, base+1, base, base+3, base+2]
p_acc = add(pos, "f", 24, "VEC3", minmax=([-h]*3, [h]*3))
n_acc = add(nrm, "f", 24, "VEC3")
t_acc = add(bulge, "f", 24, "VEC3", minmax=([0,0,0],[0,0.15,0]))
i_acc = add(idx, "H", 36, "SCALAR", comp=5123)
src["materials"].append({"name": "gold", "pbrMetallicRoughness": {"baseColorFactor": [0.9, 0.7, 0.3, 1], "metallicFactor": 1.0, "roughnessFactor": 0.35}})
src["meshes"].append({"name": "cube", "weights": [0.0], "primitives": [{"attributes": {"POSITION": p_acc, "NORMAL": n_acc},
                      "indices": i_acc, "material": len(src["materials"]) - 1, "targets": [{"POSITION": t_acc}]}]})
src["nodes"].append({"name": "cube", "mesh": len(src["meshes"]) - 1, "translation": [0, 0.35, 0]})
cube = len(src["nodes"]) - 1
src["scenes"][0]["nodes"].append(cube)
cam = next(i for i, n in enumerate(src["nodes"]) if "camera" in n)
m = src["nodes"][cam].pop("matrix")
src["nodes"][cam]["translation"] = m[12:15]  # the box's camera is unrotated

times = [0.0, 0.5, 1.0, 1.5, 2.0]
t_acc = add(times, "f", 5, "SCALAR", minmax=([0.0], [2.0]))
rot = []
for t in times:  # a full turn about y in two seconds, slerped between quarter turns
    a = math.pi * t / 2
    rot += [0, math.sin(a), 0, math.cos(a)]
r_acc = add(rot, "f", 5, "VEC4")
bounce = []  # CUBICSPLINE: in-tangent, value, out-tangent per key; up at 0.5 and 1.5 s
for t in times:
    y = 0.35 + (0.35 if t in (0.5, 1.5) else 0.0)
    slope = 0.0 if t in (0.5, 1.5) else 1.4
    bounce += [0, slope, 0, 0, y, 0, 0, slope, 0]
b_acc = add(bounce, "f", 15, "VEC3")
s_times = add([0.0, 1.0], "f", 2, "SCALAR", minmax=([0.0], [1.0]))
s_acc = add([1, 1, 1, 0.8, 0.8, 0.8], "f", 2, "VEC3")  # STEP: smaller from 1 s on
w_acc = add([0.0, 1.0, 0.0, 1.0, 0.0], "f", 5, "SCALAR")
d_times = add([0.0, 2.0], "f", 2, "SCALAR", minmax=([0.0], [2.0]))
z0 = m[14]
d_acc = add([m[12], m[13], z0, m[12], m[13], z0 - 1.2], "f", 2, "VEC3")
src["animations"] = [
    {"name": "Cube", "samplers": [{"input": t_acc, "output": r_acc, "interpolation": "LINEAR"},
                                  {"input": t_acc, "output": b_acc, "interpolation": "CUBICSPLINE"},
                                  {"input": s_times, "output": s_acc, "interpolation": "STEP"},
                                  {"input": t_acc, "output": w_acc, "interpolation": "LINEAR"}],
     "channels": [{"sampler": 0, "target": {"node": cube, "path": "rotation"}},
                  {"sampler": 1, "target": {"node": cube, "path": "translation"}},
                  {"sampler": 2, "target": {"node": cube, "path": "scale"}},
                  {"sampler": 3, "target": {"node": cube, "path": "weights"}}]},
    {"name": "Dolly", "samplers": [{"input": d_times, "output": d_acc, "interpolation": "LINEAR"}],
     "channels": [{"sampler": 0, "target": {"node": cam, "path": "translation"}}]},
]
src["buffers"][0] = {"byteLength": len(buf), "uri": "data:application/octet-stream;base64," + base64.b64encode(bytes(buf)).decode()}
src["asset"]["generator"] = "Tessera scenes/sources/cornell_shot.py"
with open("scenes/cornell_shot.gltf", "w") as f:
    json.dump(src, f, indent=1)
