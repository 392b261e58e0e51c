//! The flat list of primitives every tracer is built from.

use glam::Vec3;

use super::{Aabb, Hit, Ray, Sphere, SurfaceInteraction, TriangleTest, triangle};

/// A triangle by its three vertices (winding defines the geometric normal).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Triangle {
    /// Vertices 0, 1, 2.
    pub v: [Vec3; 3],
}

impl Triangle {
    /// Bounding box.
    #[inline]
    pub fn bounds(&self) -> Aabb {
        Aabb::new(self.v[0].min(self.v[1]).min(self.v[2]), self.v[0].max(self.v[1]).max(self.v[2]))
    }

    /// Unnormalised geometric normal `(v1 - v0) x (v2 - v0)`.
    #[inline]
    pub fn normal(&self) -> Vec3 {
        (self.v[1] - self.v[0]).cross(self.v[2] - self.v[0])
    }

    /// Twice the area (finite for vertices within [`crate::limits::MAX_COORDINATE`]).
    pub fn double_area(&self) -> f32 {
        super::scaled_length(self.normal())
    }
}

/// One primitive of [`Primitives`], by reference.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Prim<'a> {
    /// A triangle.
    Triangle(&'a Triangle),
    /// A sphere.
    Sphere(&'a Sphere),
}

/// All geometry of a scene as seen by a tracer: triangles get primitive ids
/// `0..triangles.len()`, spheres the ids after them.
#[derive(Clone, Debug, Default)]
pub struct Primitives {
    /// Triangles, in scene order.
    pub triangles: Vec<Triangle>,
    /// Analytic spheres.
    pub spheres: Vec<Sphere>,
}

impl Primitives {
    /// Number of primitives.
    #[inline]
    pub fn len(&self) -> usize {
        self.triangles.len() + self.spheres.len()
    }

    /// True when there is nothing to hit.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Primitive `i` (triangles first, then spheres): the one place the
    /// global id is decoded.
    #[inline]
    pub fn get(&self, i: usize) -> Prim<'_> {
        let nt = self.triangles.len();
        if i < nt { Prim::Triangle(&self.triangles[i]) } else { Prim::Sphere(&self.spheres[i - nt]) }
    }

    /// The primitive id of sphere `j` (the inverse of [`Primitives::sphere_index`]).
    #[inline]
    pub fn sphere_id(&self, j: usize) -> u32 {
        (self.triangles.len() + j) as u32
    }

    /// Sphere index of primitive `i`, `None` for a triangle.
    #[inline]
    pub fn sphere_index(&self, i: usize) -> Option<usize> {
        i.checked_sub(self.triangles.len())
    }

    /// The surface interaction of `hit` along `ray`, computed by the primitive hit.
    #[inline]
    pub fn interaction(&self, ray: &Ray, hit: &Hit) -> SurfaceInteraction {
        match self.get(hit.prim as usize) {
            Prim::Triangle(t) => t.interaction(hit),
            Prim::Sphere(s) => s.interaction(ray, hit),
        }
    }

    /// Bounding box of primitive `i`.
    #[inline]
    pub fn bounds(&self, i: usize) -> Aabb {
        match self.get(i) {
            Prim::Triangle(t) => t.bounds(),
            Prim::Sphere(s) => s.bounds(),
        }
    }

    /// Centroid of primitive `i`'s bounding box (what BVH builders split on).
    #[inline]
    pub fn centroid(&self, i: usize) -> Vec3 {
        self.bounds(i).center()
    }

    /// Bounding box of everything.
    pub fn world_bounds(&self) -> Aabb {
        (0..self.len()).fold(Aabb::EMPTY, |b, i| b.union(self.bounds(i)))
    }

    /// Intersect primitive `i` with `ray`: `Some((t, u, v))` within the ray's interval.
    /// `wr` holds the per-ray constants of the watertight test.
    #[inline]
    pub fn intersect_prim(
        &self,
        i: usize,
        ray: &Ray,
        wr: &triangle::WatertightRay,
        test: TriangleTest,
    ) -> Option<(f32, f32, f32)> {
        crate::with_triangle_kernel!(test, K => self.intersect_prim_with::<K>(i, ray, wr))
    }

    /// [`Self::intersect_prim`] with the triangle test chosen by type.
    #[inline(always)]
    pub fn intersect_prim_with<K: triangle::TriangleKernel>(
        &self,
        i: usize,
        ray: &Ray,
        wr: &triangle::WatertightRay,
    ) -> Option<(f32, f32, f32)> {
        match self.get(i) {
            Prim::Triangle(t) => {
                let [a, b, c] = t.v;
                K::intersect(ray, wr, a, b, c)
            }
            Prim::Sphere(s) => s.intersect(ray),
        }
    }
}
