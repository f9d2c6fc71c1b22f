//! Procedural primitives as triangle-list `Mesh`es: plane, box, cylinder, sphere, torus,
//! and a noise-displaced ("bumpy") sphere for the dense scenes.
//!
//! Conventions shared by every primitive: Y is up, the shape is centred on the origin
//! (the plane lies in y = 0), triangles wind counter-clockwise seen from outside, and
//! normals are per vertex. Flat faces get their own vertices so their normals stay flat.

use super::Mesh;
use glam::{Vec2, Vec3};
use std::f32::consts::TAU;

/// Builds a (nu+1) x (nv+1) vertex grid from a parametric surface and stitches quads.
/// `f(u, v)` returns a position and its outward normal for u, v in [0,1].
/// Triangles whose area is zero (the poles of a sphere) are dropped.
fn grid(mesh: &mut Mesh, nu: u32, nv: u32, f: impl Fn(f32, f32) -> (Vec3, Vec3)) {
    let base = mesh.positions.len() as u32;
    for j in 0..=nv {
        for i in 0..=nu {
            let (p, n) = f(i as f32 / nu as f32, j as f32 / nv as f32);
            mesh.positions.push(p);
            mesh.normals.push(n);
        }
    }
    let row = nu + 1;
    for j in 0..nv {
        for i in 0..nu {
            let a = base + j * row + i;
            let b = a + 1;
            let c = a + row + 1;
            let d = a + row;
            for tri in [[a, b, c], [a, c, d]] {
                push_oriented(mesh, tri);
            }
        }
    }
}

/// Appends a triangle wound so that its geometric normal agrees with its vertex normals.
/// The parameterisations differ in handedness; picking the winding from the normals keeps
/// every primitive outward-facing without per-shape sign bookkeeping.
fn push_oriented(mesh: &mut Mesh, [a, b, c]: [u32; 3]) {
    let (pa, pb, pc) = (
        mesh.positions[a as usize],
        mesh.positions[b as usize],
        mesh.positions[c as usize],
    );
    let g = (pb - pa).cross(pc - pa);
    let scale = (pb - pa).length_squared().max((pc - pa).length_squared());
    if g.length_squared() <= 1e-12 * scale * scale || scale == 0.0 {
        return;
    }
    let n = mesh.normals[a as usize] + mesh.normals[b as usize] + mesh.normals[c as usize];
    if g.dot(n) >= 0.0 {
        mesh.indices.extend_from_slice(&[a, b, c]);
    } else {
        mesh.indices.extend_from_slice(&[a, c, b]);
    }
}

/// A flat rectangle with corners `origin`, `origin + du`, `origin + dv`, `origin + du + dv`,
/// facing `normal`, split into `segments` x `segments` quads.
fn quad(mesh: &mut Mesh, origin: Vec3, du: Vec3, dv: Vec3, normal: Vec3, segments: u32) {
    grid(mesh, segments, segments, |u, v| {
        (origin + du * u + dv * v, normal)
    });
}

/// A ground plane in y = 0, `size.x` along X and `size.y` along Z, facing +Y.
/// `segments` subdivides each side (more triangles help per-vertex lighting and
/// vertex-based techniques that interpolate across the receiver).
pub fn plane(size: Vec2, segments: u32) -> Mesh {
    let mut m = Mesh::default();
    let h = size * 0.5;
    quad(
        &mut m,
        Vec3::new(-h.x, 0.0, -h.y),
        Vec3::new(size.x, 0.0, 0.0),
        Vec3::new(0.0, 0.0, size.y),
        Vec3::Y,
        segments.max(1),
    );
    m
}

/// An axis-aligned box of `size`, centred on the origin: 6 flat faces, 12 triangles.
pub fn cuboid(size: Vec3) -> Mesh {
    let mut m = Mesh::default();
    let h = size * 0.5;
    for axis in 0..3 {
        for sign in [-1.0f32, 1.0] {
            let n = Vec3::AXES[axis] * sign;
            let u = Vec3::AXES[(axis + 1) % 3] * size[(axis + 1) % 3];
            let v = Vec3::AXES[(axis + 2) % 3] * size[(axis + 2) % 3];
            let origin = n * h[axis] - u * 0.5 - v * 0.5;
            quad(&mut m, origin, u, v, n, 1);
        }
    }
    m
}

/// A closed cylinder along Y from -height/2 to +height/2: a smooth side and two flat
/// caps (fans), `4 * segments` triangles.
pub fn cylinder(radius: f32, height: f32, segments: u32) -> Mesh {
    let segments = segments.max(3);
    let mut m = Mesh::default();
    let hh = height * 0.5;
    grid(&mut m, segments, 1, |u, v| {
        let a = turn(u);
        let n = Vec3::new(a.cos(), 0.0, a.sin());
        (n * radius + Vec3::Y * (v * height - hh), n)
    });
    for sign in [-1.0f32, 1.0] {
        let n = Vec3::Y * sign;
        let centre = m.positions.len() as u32;
        m.positions.push(n * hh);
        m.normals.push(n);
        for i in 0..=segments {
            let a = turn(i as f32 / segments as f32);
            m.positions
                .push(Vec3::new(a.cos() * radius, sign * hh, a.sin() * radius));
            m.normals.push(n);
        }
        for i in 0..segments {
            push_oriented(&mut m, [centre, centre + 1 + i, centre + 2 + i]);
        }
    }
    m
}

/// A UV sphere: `segments` around Y, `rings` from pole to pole,
/// `2 * segments * (rings - 1)` triangles.
pub fn sphere(radius: f32, segments: u32, rings: u32) -> Mesh {
    bumpy_sphere(radius, segments, rings, 0.0, 0)
}

/// A torus around the Y axis in the XZ plane: tube of `minor_radius` swept along a circle
/// of `major_radius`; `2 * major_segments * minor_segments` triangles.
pub fn torus(
    major_radius: f32,
    minor_radius: f32,
    major_segments: u32,
    minor_segments: u32,
) -> Mesh {
    let mut m = Mesh::default();
    grid(
        &mut m,
        major_segments.max(3),
        minor_segments.max(3),
        |u, v| {
            let (a, b) = (turn(u), turn(v));
            let ring = Vec3::new(a.cos(), 0.0, a.sin());
            let n = ring * b.cos() + Vec3::Y * b.sin();
            (ring * major_radius + n * minor_radius, n)
        },
    );
    m
}

/// A UV sphere whose radius is modulated by a deterministic sum of sine waves in
/// random directions (seeded by `seed`): `radius * (1 + amplitude * noise)`, noise in
/// about [-1, 1]. Many small bumps give many silhouette edges per triangle, which is
/// what the dense scenes need to stress silhouette extraction. Normals are recomputed
/// from the displaced surface.
pub fn bumpy_sphere(radius: f32, segments: u32, rings: u32, amplitude: f32, seed: u64) -> Mesh {
    let mut rng = Lcg(seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ 0xD1B5_4A32_D192_ED03);
    // (direction * frequency, phase, weight): a handful of octaves of plane waves.
    let waves: Vec<(Vec3, f32, f32)> = if amplitude == 0.0 {
        Vec::new()
    } else {
        (0..12)
            .map(|k| {
                let dir = rng.unit_vec();
                let freq = 3.0 + 2.0 * k as f32;
                (
                    dir * freq,
                    rng.next_f32() * TAU,
                    1.0 / (1.0 + 0.35 * k as f32),
                )
            })
            .collect()
    };
    let total: f32 = waves.iter().map(|w| w.2).sum::<f32>().max(1e-6);
    let mut m = Mesh::default();
    grid(&mut m, segments.max(3), rings.max(2), |u, v| {
        let (a, b) = (turn(u), v * std::f32::consts::PI);
        // Pole samples must coincide exactly so the sphere closes without cracks.
        let n = if v == 0.0 {
            Vec3::NEG_Y
        } else if v == 1.0 {
            Vec3::Y
        } else {
            Vec3::new(b.sin() * a.cos(), -b.cos(), b.sin() * a.sin())
        };
        let noise: f32 = waves
            .iter()
            .map(|(k, ph, w)| w * (k.dot(n) + ph).sin())
            .sum();
        (n * radius * (1.0 + amplitude * noise / total * 1.5), n)
    });
    if amplitude != 0.0 {
        m.compute_normals();
    }
    m
}

/// Angle for a wrapping parameter: u = 1 maps exactly onto u = 0 so seams weld by value.
fn turn(u: f32) -> f32 {
    if u >= 1.0 {
        0.0
    } else {
        u * TAU
    }
}

/// A tiny deterministic generator: scene content must not depend on a platform RNG.
pub(crate) struct Lcg(pub u64);

impl Lcg {
    pub fn next_u32(&mut self) -> u32 {
        self.0 = self
            .0
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        (self.0 >> 33) as u32
    }
    /// Uniform in [0, 1).
    pub fn next_f32(&mut self) -> f32 {
        (self.next_u32() >> 8) as f32 / (1u32 << 24) as f32
    }
    pub fn range(&mut self, lo: f32, hi: f32) -> f32 {
        lo + (hi - lo) * self.next_f32()
    }
    pub fn unit_vec(&mut self) -> Vec3 {
        loop {
            let v = Vec3::new(
                self.range(-1.0, 1.0),
                self.range(-1.0, 1.0),
                self.range(-1.0, 1.0),
            );
            let l = v.length_squared();
            if l > 1e-4 && l <= 1.0 {
                return v / l.sqrt();
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every triangle faces the way its vertex normals say, and closed shapes enclose a
    /// positive volume (outward winding).
    fn check(m: &Mesh, closed: bool) {
        assert_eq!(m.positions.len(), m.normals.len());
        assert_eq!(m.indices.len() % 3, 0);
        let mut vol = 0.0f64;
        for t in m.indices.chunks_exact(3) {
            let [a, b, c] = [0, 1, 2].map(|k| m.positions[t[k] as usize]);
            let g = (b - a).cross(c - a);
            let n: Vec3 = t.iter().map(|&i| m.normals[i as usize]).sum();
            assert!(g.dot(n) > 0.0, "triangle faces against its normals");
            vol += a.dot(b.cross(c)) as f64 / 6.0;
        }
        for n in &m.normals {
            assert!((n.length() - 1.0).abs() < 1e-3);
        }
        if closed {
            assert!(vol > 0.0, "closed mesh winds inward (volume {vol})");
        }
    }

    #[test]
    fn primitives_are_outward_and_counted() {
        let p = plane(Vec2::new(4.0, 2.0), 3);
        check(&p, false);
        assert_eq!(p.triangle_count(), 18);
        let b = cuboid(Vec3::new(1.0, 2.0, 3.0));
        check(&b, true);
        assert_eq!(b.triangle_count(), 12);
        let v: f32 = b
            .indices
            .chunks_exact(3)
            .map(|t| {
                let [a, b2, c] = [0, 1, 2].map(|k| b.positions[t[k] as usize]);
                a.dot(b2.cross(c)) / 6.0
            })
            .sum();
        assert!((v - 6.0).abs() < 1e-4);
        let c = cylinder(1.0, 2.0, 16);
        check(&c, true);
        assert_eq!(c.triangle_count(), 64);
        let s = sphere(1.0, 16, 8);
        check(&s, true);
        assert_eq!(s.triangle_count(), 2 * 16 * 7);
        let t = torus(2.0, 0.5, 24, 12);
        check(&t, true);
        assert_eq!(t.triangle_count(), 2 * 24 * 12);
        let bs = bumpy_sphere(1.0, 32, 16, 0.1, 7);
        check(&bs, true);
        assert_eq!(bs.indices, bumpy_sphere(1.0, 32, 16, 0.1, 7).indices);
        assert_eq!(bs.positions, bumpy_sphere(1.0, 32, 16, 0.1, 7).positions);
    }
}
