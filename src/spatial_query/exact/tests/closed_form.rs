//! Closed-form test shapes: the signed distance (f64) to each, and the chord a ray cuts
//! through it, independent of parry and of the code under test; and a comparison of a cast
//! with them over random rays.

use bevy::math::{DVec2, DVec3, Vec3};
use parry3d::shape::SharedShape;

/// A fixed linear congruential sequence, so the tests are reproducible.
pub(super) struct Lcg(pub(super) u32);

impl Lcg {
    pub(super) fn range(&mut self, lo: f32, hi: f32) -> f32 {
        self.0 = self.0.wrapping_mul(1664525).wrapping_add(1013904223);
        lo + (hi - lo) * ((self.0 >> 8) as f32 / (1u32 << 24) as f32)
    }

    pub(super) fn vec(&mut self, half: Vec3) -> Vec3 {
        Vec3::new(
            self.range(-half.x, half.x),
            self.range(-half.y, half.y),
            self.range(-half.z, half.z),
        )
    }
}

/// The signed distance (f64) from `p` to a test shape, negative inside: closed forms,
/// independent of parry and of the code under test.
#[derive(Clone, Copy)]
pub(super) enum Solid {
    /// Capsule along y: half height, radius.
    Capsule(f64, f64),
    /// Cylinder along y: half height, radius.
    Cylinder(f64, f64),
    /// Cone along y, apex up: half height, base radius.
    Cone(f64, f64),
    /// Box of half extents, rounded by a radius.
    RoundBox(DVec3, f64),
    /// The convex hull of [`hull_points`], by its face planes (the largest signed distance
    /// to a face's plane: not the distance off the hull near its edges, but zero exactly on
    /// its surface, which is all a chord needs).
    Hull,
}

/// Twelve points about the origin (fixed), for [`Solid::Hull`].
fn hull_points() -> Vec<Vec3> {
    let mut rng = Lcg(5);
    (0..12).map(|_| rng.vec(Vec3::splat(0.6))).collect()
}

/// The face planes of the hull of [`hull_points`] (outward normal, a point on the plane),
/// computed in f64 from parry's faces: each face's normal from three of its corners.
fn hull_planes() -> &'static [(DVec3, DVec3)] {
    static PLANES: std::sync::OnceLock<Vec<(DVec3, DVec3)>> = std::sync::OnceLock::new();
    PLANES.get_or_init(|| {
        let shape = SharedShape::convex_hull(&hull_points()).unwrap();
        let hull = shape.as_convex_polyhedron().unwrap();
        let (points, corners) = (hull.points(), hull.vertices_adj_to_face());
        hull.faces()
            .iter()
            .map(|face| {
                let k = face.first_vertex_or_edge as usize;
                let [a, b, c] = [0, 1, 2].map(|i| points[corners[k + i] as usize].as_dvec3());
                let mut n = (b - a).cross(c - a).normalize();
                if n.dot(face.normal.as_dvec3()) < 0.0 {
                    n = -n;
                }
                (n, a)
            })
            .collect()
    })
}

impl Solid {
    pub(super) fn shape(self) -> SharedShape {
        match self {
            Solid::Capsule(h, r) => SharedShape::capsule_y(h as f32, r as f32),
            Solid::Cylinder(h, r) => SharedShape::cylinder(h as f32, r as f32),
            Solid::Cone(h, r) => SharedShape::cone(h as f32, r as f32),
            Solid::RoundBox(b, r) => {
                SharedShape::round_cuboid(b.x as f32, b.y as f32, b.z as f32, r as f32)
            }
            Solid::Hull => SharedShape::convex_hull(&hull_points()).unwrap(),
        }
    }

    pub(super) fn distance(self, p: DVec3) -> f64 {
        let rho = DVec2::new(p.x, p.z).length();
        match self {
            Solid::Capsule(h, r) => (p - DVec3::new(0.0, p.y.clamp(-h, h), 0.0)).length() - r,
            Solid::Cylinder(h, r) => box2(DVec2::new(rho, p.y), DVec2::new(r, h)),
            Solid::Cone(h, r) => triangle2(
                DVec2::new(rho, p.y),
                [DVec2::new(-r, -h), DVec2::new(r, -h), DVec2::new(0.0, h)],
            ),
            Solid::RoundBox(b, r) => {
                let q = p.abs() - b;
                q.max(DVec3::ZERO).length() + q.max_element().min(0.0) - r
            }
            Solid::Hull => hull_planes()
                .iter()
                .map(|&(n, on)| n.dot(p - on))
                .fold(f64::NEG_INFINITY, f64::max),
        }
    }

    /// Where the ray `o + t d` first comes within `inflate` of the shape (entry, exit), by
    /// a golden-section search for the least distance and bisections either side (the
    /// distance to a convex shape is convex along a line).
    pub(super) fn chord(self, o: DVec3, d: DVec3, inflate: f64) -> Option<(f64, f64)> {
        let f = |t: f64| self.distance(o + d * t) - inflate;
        let (mut a, mut b) = (0.0f64, 400.0f64);
        for _ in 0..300 {
            let (m1, m2) = (a + (b - a) / 3.0, b - (b - a) / 3.0);
            if f(m1) < f(m2) { b = m2 } else { a = m1 }
        }
        let low = 0.5 * (a + b);
        if f(low) > 0.0 {
            return None;
        }
        let root = |mut out: f64, mut inside: f64| {
            for _ in 0..200 {
                let m = 0.5 * (out + inside);
                if f(m) > 0.0 { out = m } else { inside = m }
            }
            0.5 * (out + inside)
        };
        let entry = if f(0.0) <= 0.0 { 0.0 } else { root(0.0, low) };
        Some((entry, root(800.0, low)))
    }
}

/// Signed distance to the box `[-b, b]` in 2D.
fn box2(p: DVec2, b: DVec2) -> f64 {
    let q = p.abs() - b;
    q.max(DVec2::ZERO).length() + q.max_element().min(0.0)
}

/// Signed distance to a counter-clockwise triangle in 2D.
fn triangle2(p: DVec2, v: [DVec2; 3]) -> f64 {
    let mut d = f64::INFINITY;
    let mut inside = true;
    for k in 0..3 {
        let (a, b) = (v[k], v[(k + 1) % 3]);
        let e = b - a;
        let s = ((p - a).dot(e) / e.length_squared()).clamp(0.0, 1.0);
        d = d.min((p - a - e * s).length());
        inside &= e.perp_dot(p - a) >= 0.0;
    }
    if inside { -d } else { d }
}

pub(super) const SOLIDS: [Solid; 5] = [
    Solid::Capsule(0.6, 0.3),
    Solid::Cylinder(0.6, 0.3),
    Solid::Cone(0.5, 0.4),
    Solid::RoundBox(DVec3::new(0.4, 0.3, 0.2), 0.05),
    Solid::Hull,
];

/// How a cast of `n` random rays (or balls of `inflate` m) from 1 to 50 m away, aimed at
/// the region of `solid`, compares with its closed-form chord.
pub(super) struct Compared {
    /// The largest error of the distance, over `1 + d`, on rays meeting the surface at an
    /// angle whose cosine is at least 0.01.
    pub(super) error: f64,
    /// The same times that cosine: the gap left across the surface.
    pub(super) gap: f64,
    /// The largest distance from the surface of a hit point on rays nearer tangent.
    pub(super) graze: f64,
    /// The longest chord missed, m.
    pub(super) missed: f64,
}

pub(super) fn compare(
    solid: Solid,
    inflate: f64,
    n: usize,
    cast: impl Fn(&SharedShape, Vec3, Vec3) -> Option<f32>,
) -> Compared {
    let shape = solid.shape();
    let mut rng = Lcg(99);
    let (mut error, mut gap, mut graze, mut missed) = (0.0f64, 0.0f64, 0.0f64, 0.0f64);
    for _ in 0..n {
        let far = rng.range(1.0, 50.0);
        let dir = rng.vec(Vec3::ONE).normalize();
        let origin = rng.vec(Vec3::new(0.6, 0.9, 0.6)) - dir * far;
        let (o, d) = (origin.as_dvec3(), dir.as_dvec3());
        let chord = solid.chord(o, d, inflate);
        match (cast(&shape, origin, dir), chord) {
            (Some(t), Some((entry, _))) if entry > 0.0 => {
                let p = o + d * entry;
                let eps = 1e-7;
                let grad = DVec3::new(
                    solid.distance(p + DVec3::X * eps) - solid.distance(p - DVec3::X * eps),
                    solid.distance(p + DVec3::Y * eps) - solid.distance(p - DVec3::Y * eps),
                    solid.distance(p + DVec3::Z * eps) - solid.distance(p - DVec3::Z * eps),
                )
                .normalize();
                if -grad.dot(d) >= 0.01 {
                    let off = (t as f64 - entry).abs() / (1.0 + far as f64);
                    error = error.max(off);
                    gap = gap.max(off * -grad.dot(d));
                } else {
                    let off = (solid.distance(o + d * t as f64) - inflate).abs();
                    graze = graze.max(off);
                }
            }
            (Some(t), None) => {
                let off = (solid.distance(o + d * t as f64) - inflate).abs();
                graze = graze.max(off);
            }
            (None, Some((entry, exit))) => missed = missed.max(exit - entry),
            _ => {}
        }
    }
    Compared {
        error,
        gap,
        graze,
        missed,
    }
}
