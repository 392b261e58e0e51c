"""Mitsuba 3 side of rtdiff's image oracle: the reports' Whitted integrator as a Mitsuba plugin,
and a render loop over a scene exported by `rtdiff export SCENE --to mitsuba -o DIR`.

Mitsuba 3 has no Phong BSDF, no Whitted integrator, no segment light and no parallelogram light
with bilinear corner colours. `rtdiff_whitted` (registered with `mi.register_integrator`) adds them:
it intersects with Mitsuba's `scene.ray_intersect` / `ray_test`, takes camera rays from Mitsuba's
sensor (`perspective` / `thinlens`), looks up kd through Mitsuba's `diffuse` BSDF and `bitmap`
texture (nearest / bilinear, clamped), draws random numbers from Mitsuba's sampler, and spawns
secondary rays with Mitsuba's own offsets. Only the shading formulas are written here, from the
course reports (../shared/seeds/), independently of rtdiff's Rust code:

  phong:    sum over light samples of  I * (Kd max(0, n.l) + Ks max(0, r.v)^Ns) / N
  physical: Lambert Kd/pi; point and segment samples I / r^2 (segment: length / N per sample);
            parallelogram samples are radiance with the cosine at both ends (area / N per sample)
  both:     shadow rays (transparent blockers attenuate by 1 - opacity), mirror recursion
            weighted by Ks to max_depth, alpha blending  opacity * surface + (1 - opacity) * behind.

The render loop (`render`) samples pixel positions the way rtdiff does: the pixel centre for one
sample per pixel, an n x n jittered grid for n*n samples, uniform otherwise; times lens samples.
"""

from __future__ import annotations

import json
import math
import os
import time

import numpy as np

LLVM19 = "/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1"


def pick_variant(requested: str | None = None) -> str:
    """llvm_ad_rgb when libLLVM 19 is present (libLLVM 15 aborts on some scenes), else scalar_rgb."""
    if requested:
        return requested
    if os.path.exists(LLVM19):
        os.environ.setdefault("DRJIT_LIBLLVM_PATH", LLVM19)
        return "llvm_ad_rgb"
    return "scalar_rgb"


def setup(variant: str | None = None):
    """Select the Mitsuba variant and register the plugin; returns the mitsuba module."""
    variant = pick_variant(variant)
    import mitsuba as mi

    mi.set_variant(variant)
    _register(mi)
    return mi


def _register(mi):
    import drjit as dr

    scalar = mi.variant().startswith("scalar")

    class RtdiffWhitted(mi.SamplingIntegrator):
        """The reports' recursive ray tracer (see the module docstring)."""

        def __init__(self, props):
            super().__init__(props)
            path = props.get("config", "rtdiff.json")
            resolved = str(mi.Thread.thread().file_resolver().resolve(path))
            with open(resolved) as f:
                self.cfg = json.load(f)
            if self.cfg.get("format") != "rtdiff-mitsuba-1":
                raise ValueError(f"{resolved}: not an rtdiff export (format {self.cfg.get('format')!r})")
            self.max_depth = int(props.get("max_depth", self.cfg["max_depth"]))
            self.plan = self.cfg["plan"]
            self.mats = self.cfg["materials"]
            self.shape_material = {s["id"]: s["material"] for s in self.cfg["shapes"]}
            self.lights = self.cfg["lights"]
            self.n_samples = int(self.cfg["light_samples"])
            self.jittered = self.cfg["light_sampling"] == "jittered"
            self._shapes = None

        # --- per-lane material parameters -------------------------------------------------
        def _material_params(self, scene, si, active):
            """ks, shininess, opacity, physical (bool) at each lane's hit."""
            if self._shapes is None:
                self._shapes = [(s, self.shape_material[s.id()]) for s in scene.shapes()]
            ks = mi.Color3f(0.0)
            shin = mi.Float(1.0)
            opac = mi.Float(1.0)
            phys = mi.Bool(False)
            if scalar:
                if not active:
                    return ks, shin, opac, phys
                m = self.mats[self.shape_material[si.shape.id()]]
                return mi.Color3f(*m["ks"]), mi.Float(m["shininess"]), mi.Float(m["opacity"]), m["model"] == "physical"
            for shape, mat in self._shapes:
                m = self.mats[mat]
                here = active & (si.shape == mi.ShapePtr(shape))
                ks = dr.select(here, mi.Color3f(*m["ks"]), ks)
                shin = dr.select(here, m["shininess"], shin)
                opac = dr.select(here, m["opacity"], opac)
                phys = phys | (here & (m["model"] == "physical"))
            return ks, shin, opac, phys

        def _opacity(self, scene, si, active):
            return self._material_params(scene, si, active)[2]

        # --- light samples ---------------------------------------------------------------
        def _light_samples(self, sampler, active):
            """Yield (position, colour, average_weight, measure, normal or None, is_point) per sample."""
            n = max(self.n_samples, 1)
            for L in self.lights:
                if L["type"] == "point":
                    yield mi.Point3f(*L["position"]), mi.Color3f(*L["color"]), 1.0, 1.0, None, True
                elif L["type"] == "segment":
                    p0, p1 = mi.Point3f(*L["endpoints"][0]), mi.Point3f(*L["endpoints"][1])
                    c0, c1 = mi.Color3f(*L["colors"][0]), mi.Color3f(*L["colors"][1])
                    length = float(np.linalg.norm(np.subtract(L["endpoints"][1], L["endpoints"][0])))
                    for i in range(n):
                        u = sampler.next_1d(active)
                        t = (i + u) / n if self.jittered else u
                        yield p0 + t * (p1 - p0), (1 - t) * c0 + t * c1, 1.0 / n, length / n, None, False
                else:
                    v0, e1, e2 = (mi.Vector3f(*L[k]) for k in ("v0", "edge01", "edge02"))
                    c = [mi.Color3f(*x) for x in L["colors"]]
                    cross = np.cross(L["edge01"], L["edge02"])
                    area = float(np.linalg.norm(cross))
                    normal = mi.Vector3f(*(cross / area).tolist())
                    if self.jittered:
                        k = math.ceil(math.sqrt(n))
                        cells = [(i, j, k) for i in range(k) for j in range(k)]
                    else:
                        cells = [(0, 0, 1)] * n
                    count = len(cells)
                    for i, j, k in cells:
                        s = sampler.next_2d(active)
                        a, b = (i + s.x) / k, (j + s.y) / k
                        col = (1 - a) * ((1 - b) * c[0] + b * c[2]) + a * ((1 - b) * c[1] + b * c[3])
                        yield mi.Point3f(v0 + a * e1 + b * e2), col, 1.0 / count, area / count, normal, False

        # --- shadow rays -----------------------------------------------------------------
        def _visibility(self, scene, si, target, active):
            """Fraction of light from `target` reaching `si`: 0/1, attenuated by transparent blockers."""
            ray = si.spawn_ray_to(target)
            if not self.plan["transparency"]:
                return dr.select(active & scene.ray_test(ray, active), 0.0, 1.0)
            trans = mi.Float(1.0)
            alive = mi.Bool(active)
            for _ in range(64):
                hit = scene.ray_intersect(ray, alive)
                blocked = alive & hit.is_valid()
                op = self._opacity(scene, hit, blocked)
                trans = dr.select(blocked, trans * (1.0 - op), trans)
                alive = blocked & (op < 1.0)
                trans = dr.select(blocked & (op >= 1.0), 0.0, trans)
                if not dr.any(alive):
                    break
                ray = dr.select(alive, hit.spawn_ray_to(target), ray) if not scalar else hit.spawn_ray_to(target)
            return dr.select(alive, 0.0, trans) if not scalar else (0.0 if alive else trans)

        # --- shading ---------------------------------------------------------------------
        def _direct(self, scene, sampler, si, p, ns, wo, kd, ks, shin, phys, active):
            total = mi.Color3f(0.0)
            for pos, col, avg_w, measure, normal, is_point in self._light_samples(sampler, active):
                if not is_point and not self.plan["area_lights"]:
                    continue
                shadows = self.plan["hard_shadows"] if is_point else self.plan["soft_shadows"]
                d = pos - p
                r2 = dr.squared_norm(d)
                l = d * dr.rsqrt(dr.maximum(r2, 1e-30))
                ndl = dr.dot(ns, l)
                lit = active & (ndl > 0.0) & (r2 > 0.0)
                # Phong (the reports): I (Kd n.l + Ks max(0, r.v)^Ns) / N, no falloff.
                r = 2.0 * ndl * ns - l
                rdv = dr.dot(r, wo)
                spec = dr.select(rdv > 0.0, ks * dr.power(dr.maximum(rdv, 1e-30), shin), 0.0)
                spec = dr.select(dr.all(ks == 0.0), 0.0, spec)
                phong = col * (kd * ndl + spec) * avg_w
                # Physical: Kd/pi * I * cos * cos_light * measure / r^2.
                cos_light = 1.0 if normal is None else dr.maximum(dr.dot(-l, normal), 0.0)
                physical = kd * dr.inv_pi * col * (ndl * cos_light * measure / r2)
                f = dr.select(phys, physical, phong)
                f = dr.select(lit, f, 0.0)
                if shadows:
                    vis = self._visibility(scene, si, pos, lit)
                    f = f * vis
                total += f
            return total

        def trace(self, scene, sampler, ray, depth, active):
            bg = mi.Color3f(*self.cfg["background"])
            si = scene.ray_intersect(ray, active)
            valid = active & si.is_valid()
            result = dr.select(valid, mi.Color3f(0.0), bg)
            if not dr.any(valid):
                return result
            d = dr.normalize(ray.d)
            ng = mi.Vector3f(si.n)
            ns = mi.Vector3f(si.sh_frame.n)
            # Two-sided shading: both normals on the side the ray came from.
            ng = dr.select(dr.dot(ng, d) > 0.0, -ng, ng)
            ns = dr.select(dr.dot(ns, ng) < 0.0, -ns, ns)
            ks, shin, opac, phys = self._material_params(scene, si, valid)
            bsdf = si.bsdf(ray)
            kd = mi.Color3f(bsdf.eval_diffuse_reflectance(si, valid))
            if self.plan["shading"]:
                color = self._direct(scene, sampler, si, si.p, ns, -d, kd, ks, shin, phys, valid)
            else:
                color = kd
            deeper = depth < self.max_depth
            if self.plan["reflections"] and deeper:
                refl = valid & dr.any(ks != 0.0)
                if dr.any(refl):
                    r = dr.normalize(d - 2.0 * dr.dot(d, ns) * ns)
                    sub = self.trace(scene, sampler, si.spawn_ray(r), depth + 1, refl)
                    color = dr.select(refl, color + ks * sub, color)
            if self.plan["transparency"] and deeper:
                see = valid & (opac < 1.0)
                if dr.any(see):
                    behind = self.trace(scene, sampler, si.spawn_ray(d), depth + 1, see)
                    color = dr.select(see, opac * color + (1.0 - opac) * behind, color)
            return dr.select(valid, color, result)

        def sample(self, scene, sampler, ray, medium=None, active=True):
            L = self.trace(scene, sampler, mi.Ray3f(ray), 0, mi.Bool(active))
            return mi.Spectrum(L), mi.Bool(active), []

        def aov_names(self):
            return []

        def to_string(self):
            return f"RtdiffWhitted[max_depth={self.max_depth}]"

    mi.register_integrator("rtdiff_whitted", lambda props: RtdiffWhitted(props))


def load(mi, scene_dir: str):
    """Load DIR/scene.xml without merging shapes (the integrator maps shape ids to materials)."""
    return mi.load_file(os.path.join(scene_dir, "scene.xml"), optimize=False)


def config(scene_dir: str) -> dict:
    with open(os.path.join(scene_dir, "rtdiff.json")) as f:
        return json.load(f)


def render(mi, scene, cfg: dict, seed: int, passes: int | None = None) -> np.ndarray:
    """One image (H x W x 3 float32): the mean of `passes` samples per pixel, pixel positions as
    rtdiff places them (centre for spp 1, n x n jittered grid for n*n, uniform otherwise), each
    with one lens sample when depth of field is on. `passes` defaults to spp * dof_samples."""
    import drjit as dr

    W, H = int(cfg["width"]), int(cfg["height"])
    spp, dof = int(cfg["spp"]), int(cfg["dof_samples"])
    passes = passes or spp * dof
    sensor = scene.sensors()[0]
    integrator = scene.integrator()
    sampler = mi.load_dict({"type": "independent"})
    k = round(math.sqrt(spp))
    square = k * k == spp and spp > 1
    scalar = mi.variant().startswith("scalar")
    acc = np.zeros((H, W, 3), dtype=np.float64)
    lens_on = cfg["plan"]["depth_of_field"]
    for p in range(passes):
        s = p // dof  # camera sample index (each camera sample gets `dof` lens samples)
        stream = (seed * 1_000_003 + p) & 0x7FFFFFFF
        if scalar:
            for y in range(H):
                for x in range(W):
                    sampler.seed(stream * W * H + y * W + x, 1)
                    L = _camera_sample(mi, sensor, integrator, scene, sampler, x, y, W, H, spp, s, k, square, lens_on)
                    acc[y, x] += np.array([L[0], L[1], L[2]], dtype=np.float64)
            continue
        sampler.seed(stream, W * H)
        idx = dr.arange(mi.UInt32, W * H)
        x, y = mi.Float(idx % W), mi.Float(idx // W)
        L = _camera_sample(mi, sensor, integrator, scene, sampler, x, y, W, H, spp, s, k, square, lens_on)
        dr.eval(L)
        acc += np.stack([np.array(L[0]), np.array(L[1]), np.array(L[2])], axis=-1).reshape(H, W, 3)
    return (acc / passes).astype(np.float32)


def _camera_sample(mi, sensor, integrator, scene, sampler, x, y, W, H, spp, s, k, square, lens_on):
    """Radiance of camera sample `s` in pixel(s) (x, y): the centre for spp 1, stratum (s % k, s // k)
    of a k x k jittered grid for a square spp, uniform otherwise; one lens sample when lens_on."""
    if spp == 1:
        ox, oy = 0.5, 0.5
    elif square:
        j = sampler.next_2d()
        cx, cy = s % k, s // k
        if not mi.variant().startswith("scalar"):
            # Opaque: one JIT kernel serves every stratum (a literal would compile one per pass).
            import drjit as dr

            cx, cy = dr.opaque(mi.Float, cx), dr.opaque(mi.Float, cy)
        ox, oy = (cx + j.x) / k, (cy + j.y) / k
    else:
        j = sampler.next_2d()
        ox, oy = j.x, j.y
    lens = sampler.next_2d() if lens_on else mi.Point2f(0.5, 0.5)
    ray, _ = sensor.sample_ray(0.0, 0.5, mi.Point2f((x + ox) / W, (y + oy) / H), lens)
    L, _, _ = integrator.sample(scene, sampler, ray)
    return L


def write_exr(path: str, img: np.ndarray):
    """Byte-deterministic linear float32 RGB EXR (scanline, zip, written by OpenImageIO in one thread)."""
    import OpenImageIO as oiio

    oiio.attribute("threads", 1)
    h, w, _ = img.shape
    spec = oiio.ImageSpec(w, h, 3, oiio.FLOAT)
    spec.channelnames = ("R", "G", "B")
    spec.attribute("compression", "zip")
    spec.attribute("openexr:lineOrder", "increasingY")
    spec.attribute("DateTime", "")  # OpenEXR would stamp the time: no timestamp, byte-identical files
    out = oiio.ImageOutput.create(path)
    if out is None or not out.open(path, spec):
        raise OSError(f"{path}: cannot write EXR: {oiio.geterror()}")
    out.write_image(np.ascontiguousarray(img, dtype=np.float32))
    out.close()


def read_exr(path: str) -> np.ndarray:
    import OpenImageIO as oiio

    buf = oiio.ImageBuf(path)
    if buf.has_error:
        raise OSError(f"{path}: {buf.geterror()}")
    return buf.get_pixels(oiio.FLOAT)[:, :, :3]


def timed_render(mi, scene_dir: str, seed: int, passes: int | None = None):
    cfg = config(scene_dir)
    scene = load(mi, scene_dir)
    t0 = time.perf_counter()
    img = render(mi, scene, cfg, seed, passes)
    return img, time.perf_counter() - t0, cfg
