#!/usr/bin/env python3
"""Convert a Mitsuba 3 scene (XML) into an rtdiff scene: DIR/scene.json and DIR/meshes/*.obj.

  .venv/bin/python scripts/mitsuba/import_scene.py SCENE.xml -o DIR [--spp 4] [--light-samples 16]

Mitsuba itself loads the XML (so its parser, transforms and built-in shapes decide the geometry);
the scene is then read back from Mitsuba's objects: mesh vertices in world space (float32, written
with 9 significant digits, which round-trip exactly), rectangles as two triangles from their
to_world, spheres from their to_world, `diffuse` reflectances (an rgb value; inside `twosided` too),
`area` emitters with one radiance on a rectangle (rtdiff's uniform parallelogram light, front side
kept), `point` emitters, and the `perspective` sensor (origin, direction, up, vertical field of
view, film size). rtdiff renders it in its physical model (Lambert Kd/pi, I/r^2, area radiance):
Mitsuba's units. Anything outside that subset (other shapes, BSDFs, emitters, sensors, textured
BSDFs, emitters on other shapes) is refused with its id and type: nothing is dropped silently. The
integrator, sampler and reconstruction filter are not imported: rtdiff uses its own (Whitted, the
given camera samples per pixel, box).
"""
import argparse
import json
import math
import os
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
import numpy as np  # noqa: E402

import rtdiff_mitsuba as rm  # noqa: E402


class Unsupported(Exception):
    """A construct outside the importer's subset."""


def f9(x):
    """A float32 written so that it reads back to the same float32."""
    return f"{float(np.float32(x)):.9g}"


def rgb_of(bsdf, mi, what):
    """The reflectance of a diffuse BSDF (possibly inside twosided), as a 3-list."""
    name = bsdf.class_name()
    params = mi.traverse(bsdf)
    if name == "TwoSidedBRDF":
        keys = [k for k in params.keys() if k.endswith("reflectance.value")]
        if len(keys) != 1 or not keys[0].startswith("brdf_0."):
            raise Unsupported(f"{what}: a twosided BSDF whose two sides differ")
        name = "SmoothDiffuse"
        key = keys[0]
    else:
        key = "reflectance.value"
    if name != "SmoothDiffuse":
        raise Unsupported(f"{what}: BSDF {name} (only diffuse, optionally twosided)")
    if key not in params:
        raise Unsupported(f"{what}: a textured diffuse reflectance (only an rgb value)")
    v = np.array(params[key], dtype=np.float64).reshape(-1)
    return [float(v[0]), float(v[1]), float(v[2])] if v.size >= 3 else [float(v[0])] * 3


def matrix(t):
    """A Mitsuba transform's 4x4 matrix as a float64 numpy array."""
    return np.array(t.matrix, dtype=np.float64).reshape(4, 4)


def apply(m, p):
    return (m @ np.array([p[0], p[1], p[2], 1.0]))[:3]


def write_obj(path, positions, faces, normals=None):
    """An OBJ of world-space float32 positions (and per-vertex normals), faces 0-based."""
    lines = ["# written by scripts/mitsuba/import_scene.py from Mitsuba's own scene\n"]
    lines += [f"v {f9(p[0])} {f9(p[1])} {f9(p[2])}\n" for p in positions]
    if normals is not None:
        lines += [f"vn {f9(n[0])} {f9(n[1])} {f9(n[2])}\n" for n in normals]
        lines += [f"f {a + 1}//{a + 1} {b + 1}//{b + 1} {c + 1}//{c + 1}\n" for a, b, c in faces]
    else:
        lines += [f"f {a + 1} {b + 1} {c + 1}\n" for a, b, c in faces]
    with open(path, "w") as f:
        f.writelines(lines)


def convert(mi, xml, out, spp, light_samples):
    scene = mi.load_file(xml, optimize=False)
    os.makedirs(os.path.join(out, "meshes"), exist_ok=True)
    materials, meshes, lights = {}, [], []
    interpolated = False
    for k, shape in enumerate(scene.shapes()):
        sid = shape.id() or f"shape{k}"
        kind = shape.class_name()
        what = f"shape '{sid}' ({kind})"
        params = mi.traverse(shape)
        emitter = shape.emitter()
        if emitter is not None:
            if kind != "Rectangle" or emitter.class_name() != "AreaLight":
                raise Unsupported(f"{what}: an emitter {emitter.class_name()} (only area emitters on rectangles)")
            ep = mi.traverse(emitter)
            if "radiance.value" not in ep:
                raise Unsupported(f"{what}: a textured radiance (only an rgb value)")
            m = matrix(params["to_world"])
            v0, v1, v2 = apply(m, (-1, -1, 0)), apply(m, (1, -1, 0)), apply(m, (-1, 1, 0))
            e01, e02 = v1 - v0, v2 - v0
            # rtdiff emits on the side of edge01 x edge02; Mitsuba's rectangle on the side of its
            # normal, to_world's inverse transpose applied to +z.
            n = np.linalg.inv(m[:3, :3]).T @ np.array([0.0, 0.0, 1.0])
            if np.dot(np.cross(e01, e02), n) < 0:
                e01, e02, v0 = e02, e01, v0
            c = np.array(ep["radiance.value"], dtype=np.float64).reshape(-1)
            c = [float(x) for x in (c if c.size >= 3 else np.repeat(c[0], 3))]
            lights.append({"type": "parallelogram", "v0": v0.tolist(), "edge01": e01.tolist(),
                           "edge02": e02.tolist(), "colors": [c, c, c, c]})
            # The light's own surface is not geometry in rtdiff (its pixels: see docs/oracles.md).
            continue
        mat = f"m_{sid}"
        materials[mat] = {"kd": rgb_of(shape.bsdf(), mi, what)}
        obj = f"meshes/{sid}.obj"
        if kind == "Rectangle":
            m = matrix(params["to_world"])
            corners = [apply(m, p) for p in [(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)]]
            write_obj(os.path.join(out, obj), corners, [(0, 1, 2), (0, 2, 3)])
        elif kind == "Mesh" or shape.is_mesh():
            pos = np.array(params["vertex_positions"], dtype=np.float32).reshape(-1, 3)
            faces = np.array(params["faces"], dtype=np.int64).reshape(-1, 3)
            nrm = None
            if "vertex_normals" in params and np.array(params["vertex_normals"]).size == pos.size:
                nrm = np.array(params["vertex_normals"], dtype=np.float32).reshape(-1, 3)
                interpolated = True
            write_obj(os.path.join(out, obj), pos, faces, nrm)
        elif kind == "Sphere":
            m = matrix(params["to_world"])
            radius = float(np.linalg.norm(m[:3, 0]))
            meshes_or_spheres = {"center": apply(m, (0, 0, 0)).tolist(), "radius": radius, "material": mat}
            meshes.append(("sphere", meshes_or_spheres))
            continue
        else:
            raise Unsupported(f"{what}: only rectangle, mesh (obj, ply, cube) and sphere shapes")
        meshes.append(("mesh", {"file": obj, "material": mat}))
    for e in scene.emitters():
        if e.class_name() == "AreaLight":
            continue
        if e.class_name() != "PointLight":
            raise Unsupported(f"emitter {e.class_name()}: only point and area emitters")
        ep = mi.traverse(e)
        c = np.array(ep["intensity.value"], dtype=np.float64).reshape(-1)
        c = [float(x) for x in (c if c.size >= 3 else np.repeat(c[0], 3))]
        lights.append({"type": "point", "position": np.array(ep["position"], dtype=np.float64).reshape(-1)[:3].tolist(),
                       "color": c})
    sensor = scene.sensors()[0]
    if sensor.class_name() != "PerspectiveCamera":
        raise Unsupported(f"sensor {sensor.class_name()}: only perspective")
    sp = mi.traverse(sensor)
    m = matrix(sp["to_world"])
    origin, up, forward = m[:3, 3], m[:3, 1], m[:3, 2]
    w, h = (int(x) for x in sensor.film().size())
    x_fov = float(np.array(sp["x_fov"]).reshape(-1)[0])
    v_fov = 2.0 * math.degrees(math.atan(math.tan(math.radians(x_fov) / 2.0) * h / w))
    doc = {
        "description": f"Imported from {os.path.basename(xml)} by scripts/mitsuba/import_scene.py (Mitsuba's own "
                       f"scene, read back from Mitsuba's objects).",
        "image": {"width": w, "height": h, "spp": spp},
        "camera": {"position": origin.tolist(), "look_at": (origin + forward).tolist(), "up": up.tolist(),
                   "fov": v_fov},
        "shading_model": "physical",
        "features": {"normal_interpolation": interpolated},
        "params": {"light_samples": light_samples, "light_sampling": "jittered"},
        "materials": materials,
        "meshes": [m for kind, m in meshes if kind == "mesh"],
        "spheres": [m for kind, m in meshes if kind == "sphere"],
        "lights": lights,
    }
    with open(os.path.join(out, "scene.json"), "w") as f:
        json.dump(doc, f, indent=1)
        f.write("\n")
    return doc


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("scene")
    ap.add_argument("-o", "--out", required=True)
    ap.add_argument("--spp", type=int, default=4, help="rtdiff camera samples per pixel (default 4)")
    ap.add_argument("--light-samples", type=int, default=16, help="area-light samples per pixel (default 16)")
    ap.add_argument("--variant", default=None)
    a = ap.parse_args()
    if not os.path.isfile(a.scene):
        sys.exit(f"import_scene.py: {a.scene}: file not found")
    mi = rm.setup(a.variant)
    try:
        doc = convert(mi, a.scene, a.out, a.spp, a.light_samples)
    except Unsupported as e:
        sys.exit(f"import_scene.py: {a.scene}: {e}")
    print(json.dumps({"scene": os.path.join(a.out, "scene.json"), "meshes": len(doc["meshes"]),
                      "spheres": len(doc["spheres"]), "lights": len(doc["lights"]),
                      "materials": len(doc["materials"])}))


if __name__ == "__main__":
    main()
