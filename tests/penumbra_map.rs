//! penumbra-map (Wyman & Hansen 2003) on lavapipe with validation: lit and umbra agree with
//! `hard`, R = 0 is `hard`, contact hardening, no inner penumbra (the umbra never shrinks as R
//! grows), and a vertex with four silhouette edges renders cleanly.

mod common;

use common::{covered, max_visibility_diff, pixel_at, small, with_radius, Gpu};
use glam::{Mat4, Vec2, Vec3};
use softshadow::output::FrameImages;
use softshadow::scene::{primitives, Camera, Light, Mesh, Object, Role, Scene};
use softshadow::settings::Settings;
use std::sync::Arc;

const PM: &str = "penumbra-map";

fn ground_pixels(img: &FrameImages) -> impl Iterator<Item = (usize, Vec3)> + '_ {
    covered(img).into_iter().filter_map(move |i| {
        let p = glam::Vec4::from(img.position[i]).truncate();
        (p.y.abs() < 1e-3).then_some((i, p))
    })
}

#[test]
fn lit_and_umbra_agree_with_hard() {
    let gpu = Gpu::new();
    let s = with_radius(small(160, 256), 0.4);
    let pm = gpu.render("cylinder", PM, s.clone());
    let hard = gpu.render("cylinder", "hard", s);
    // Between the light (at -x) and the cylinder: lit; behind it along the shadow: umbra.
    let lit = Vec3::new(-1.5, 0.0, 1.0);
    let umbra = Vec3::new(2.5, 0.0, -0.4);
    for (name, img) in [("hard", &hard), (PM, &pm)] {
        let v_lit = img.visibility[pixel_at(img, lit)];
        let v_umbra = img.visibility[pixel_at(img, umbra)];
        assert_eq!(v_lit, 1.0, "{name}: lit point");
        assert!(v_umbra < 1e-3, "{name}: umbra point {v_umbra}");
    }
    assert!(pm
        .visibility
        .iter()
        .all(|v| v.is_finite() && (0.0..=1.0).contains(v)));
    // The soft technique has a penumbra that hard lacks.
    let soft = |img: &FrameImages| {
        img.visibility
            .iter()
            .filter(|v| **v > 0.05 && **v < 0.95)
            .count()
    };
    assert!(
        soft(&pm) > 2 * soft(&hard) + 50,
        "pm {} hard {}",
        soft(&pm),
        soft(&hard)
    );
}

#[test]
fn zero_radius_equals_hard() {
    let gpu = Gpu::new();
    let s = with_radius(small(128, 256), 0.0);
    let pm = gpu.render("cylinder", PM, s.clone());
    let hard = gpu.render("cylinder", "hard", s);
    let max = max_visibility_diff(&pm, &hard);
    assert!(max <= 1e-6, "max |pm - hard| = {max}");
}

/// World z-extent of the penumbra on the camera side (+z) of the cylinder's shadow, over the
/// ground pixels with x in [x0, x1].
fn penumbra_width(img: &FrameImages, x0: f32, x1: f32) -> f32 {
    let mut lo = f32::MAX;
    let mut hi = f32::MIN;
    for (i, p) in ground_pixels(img) {
        let v = img.visibility[i];
        // The shadow's axis runs from the light (x = -6, z = 1) through the cylinder (x = z = 0).
        if p.x >= x0 && p.x <= x1 && p.z > -p.x / 6.0 && v > 0.02 && v < 0.98 {
            lo = lo.min(p.z);
            hi = hi.max(p.z);
        }
    }
    if hi < lo {
        0.0
    } else {
        hi - lo
    }
}

#[test]
fn contact_hardening() {
    let gpu = Gpu::new();
    let img = gpu.render("cylinder", PM, with_radius(small(256, 512), 0.6));
    // Near the base the casting silhouette is ~0.6 above the ground, far along the shadow ~1.7.
    let near = penumbra_width(&img, 0.7, 1.1);
    let far = penumbra_width(&img, 3.0, 3.4);
    eprintln!("penumbra width near {near:.3} far {far:.3}");
    assert!(far > 0.15, "far penumbra {far}");
    assert!(near < 0.6 * far, "near {near} far {far}");
}

#[test]
fn umbra_does_not_shrink_with_radius() {
    let gpu = Gpu::new();
    let count = |r: f32| {
        let img = gpu.render("cylinder", PM, with_radius(small(160, 256), r));
        let px = covered(&img);
        let umbra = px.iter().filter(|&&i| img.visibility[i] < 0.01).count();
        let penumbra = px
            .iter()
            .filter(|&&i| img.visibility[i] >= 0.01 && img.visibility[i] < 0.99)
            .count();
        (umbra, penumbra)
    };
    let (u_small, p_small) = count(0.15);
    let (u_big, p_big) = count(0.8);
    // Outer penumbra only: the hard shadow stays fully dark whatever R (an inner penumbra
    // would eat into it), while the penumbra widens.
    eprintln!("umbra {u_small} -> {u_big}, penumbra {p_small} -> {p_big}");
    assert!(u_big >= u_small, "umbra {u_small} -> {u_big}");
    assert!(
        p_big > p_small + p_small / 2,
        "penumbra {p_small} -> {p_big}"
    );
    assert!(u_small > 100);
}

/// Two tetrahedra touching at the origin (x mirrored), top faces in z = 0: lit from +z, the
/// origin has four silhouette edges.
fn bowtie() -> Mesh {
    let mut m = Mesh::default();
    for s in [1.0f32, -1.0] {
        let p = [
            Vec3::ZERO,
            Vec3::new(2.0 * s, -1.0, 0.0),
            Vec3::new(2.0 * s, 1.0, 0.0),
            Vec3::new(1.5 * s, 0.0, -1.0),
        ];
        let base = m.positions.len() as u32;
        let centre = (p[0] + p[1] + p[2] + p[3]) / 4.0;
        m.positions.extend_from_slice(&p);
        for t in [[0u32, 1, 2], [0, 1, 3], [0, 2, 3], [1, 2, 3]] {
            let [a, b, c] = t.map(|i| p[i as usize]);
            let n = (b - a).cross(c - a);
            let t = if n.dot(a - centre) > 0.0 {
                t
            } else {
                [t[0], t[2], t[1]]
            };
            m.indices.extend(t.map(|i| base + i));
        }
    }
    m.compute_normals();
    m
}

#[test]
fn bowtie_special_vertex_renders() {
    let gpu = Gpu::new();
    // Top faces up (+y), 1.5 above the ground.
    let model = Mat4::from_translation(Vec3::new(0.0, 1.5, 0.0))
        * Mat4::from_rotation_x(-std::f32::consts::FRAC_PI_2);
    let scene = Scene {
        name: "bowtie".into(),
        objects: vec![
            Object::new(
                "ground",
                Arc::new(primitives::plane(Vec2::splat(12.0), 4)),
                Mat4::IDENTITY,
                Role::Receiver,
                Vec3::splat(0.8),
            ),
            Object::new(
                "bowtie",
                Arc::new(bowtie()),
                model,
                Role::Both,
                Vec3::new(0.8, 0.4, 0.3),
            ),
        ],
        light: Light {
            position: Vec3::new(0.3, 8.0, 0.2),
            target: Vec3::ZERO,
            fov_deg: 60.0,
            radius: 0.5,
            kind: softshadow::scene::LightKind::Spot,
        },
        camera: Camera {
            position: Vec3::new(0.0, 7.0, 6.0),
            target: Vec3::ZERO,
            up: Vec3::Y,
            fov_deg: 50.0,
        },
    };
    let (img, _) = gpu.render_frames(scene, PM, small(160, 256), 2);
    assert!(img
        .visibility
        .iter()
        .all(|v| v.is_finite() && (0.0..=1.0).contains(v)));
    // Under the touching point: umbra; a soft edge around the shadow.
    let ground: Vec<usize> = ground_pixels(&img).map(|(i, _)| i).collect();
    let under = pixel_at(&img, Vec3::new(0.8, 0.0, 0.0));
    assert!(img.visibility[under] < 0.01, "{}", img.visibility[under]);
    assert!(ground
        .iter()
        .any(|&i| img.visibility[i] > 0.1 && img.visibility[i] < 0.9));
}

/// The cylinder scene plus a square plate of side `side` x the light distance, 1 % of the way
/// from the light and a little off its axis (stress case `blocker-near-light`).
fn with_near_light_plate(side: f32) -> Scene {
    let mut s = Scene::load("cylinder").unwrap_or_else(|e| panic!("{e:#}"));
    let l = s.light;
    let d = l.target - l.position;
    let off = d.cross(Vec3::Y).normalize_or(Vec3::X) * d.length() * (0.002 + side * 0.5);
    s.objects.push(Object::new(
        "plate",
        Arc::new(primitives::cuboid(Vec3::new(
            d.length() * side,
            d.length() * 1e-4,
            d.length() * side,
        ))),
        Mat4::from_translation(l.position + d * 0.01 + off),
        Role::Caster,
        Vec3::ONE,
    ));
    s
}

/// Ground pixels outside every hard shadow (per `hard` of the same scene).
fn hard_lit_ground(gpu: &Gpu, scene: &Scene, s: &Settings) -> Vec<usize> {
    let (hard, _) = gpu.render_frames(scene.clone(), "hard", s.clone(), 1);
    ground_pixels(&hard)
        .filter(|&(i, _)| hard.visibility[i] == 1.0)
        .map(|(i, _)| i)
        .collect()
}

#[test]
fn tiny_caster_near_the_light_darkens_nothing_around_its_hard_shadow() {
    // A plate 1e-3 of the light distance wide at 1 % of it hides ~1e-4 of the light from the
    // ground. Without the blocker-size bound its cones (radius ~ Lr / Zv x depth, wider than
    // the map) give Eq. 1 intensities ~1e-6 over the whole ground, which a single
    // own-surface window shows as rings of 0.4..0.8.
    let gpu = Gpu::new();
    let s = small(128, 256);
    let plate = with_near_light_plate(1e-3);
    let plain = Scene::load("cylinder").unwrap_or_else(|e| panic!("{e:#}"));
    let lit = hard_lit_ground(&gpu, &plate, &s);
    let (with, _) = gpu.render_frames(plate, PM, s.clone(), 1);
    let (without, _) = gpu.render_frames(plain, PM, s, 1);
    assert!(lit.len() > 2000, "{} lit ground pixels", lit.len());
    let worst = lit
        .iter()
        .map(|&i| (with.visibility[i] - without.visibility[i]).abs())
        .fold(0.0f32, f32::max);
    // The bound leaves 1 - 4 r / (pi Lr) ~ 0.985 under the cones; 0.05 with filtering.
    assert!(
        worst < 0.05,
        "the plate changed lit ground by up to {worst}"
    );
}

#[test]
fn wide_penumbra_on_a_sloped_receiver_is_smooth() {
    // A plate three light radii wide at 10 % of the light distance, just outside the light's
    // frustum: no hard shadow, but its cones sweep over much of the ground, where the
    // penumbra map is dark and smooth. A single own-surface window (1 % of the point's depth
    // for all four texels of the footprint) misreads ground texels one texel away on this
    // receiver (~0.5-0.8 % of depth a texel at 256^2) as background and shows the map only
    // on the others: a moire of rings (stress cases `blocker-near-light`, `near-far-1e-4`).
    // Count neighbouring ground pixels whose visibility jumps.
    let gpu = Gpu::new();
    let s = small(128, 256);
    let mut scene = Scene::load("cylinder").unwrap_or_else(|e| panic!("{e:#}"));
    let l = scene.light;
    let d = l.target - l.position;
    let depth = d.length() * 0.1;
    let side = d.cross(Vec3::Y).normalize_or(Vec3::X);
    let edge = (l.fov_deg.to_radians() * 0.5).tan() * depth;
    let w = 3.0 * l.radius;
    scene.objects.push(Object::new(
        "plate",
        Arc::new(primitives::cuboid(Vec3::new(w, w * 0.01, w))),
        Mat4::from_translation(l.position + d.normalize() * depth + side * (edge * 1.05 + w * 0.5)),
        Role::Caster,
        Vec3::ONE,
    ));
    let lit: std::collections::HashSet<usize> =
        hard_lit_ground(&gpu, &scene, &s).into_iter().collect();
    let (img, _) = gpu.render_frames(scene, PM, s, 1);
    let dark = lit.iter().filter(|&&i| img.visibility[i] < 0.5).count();
    let wd = img.width as usize;
    let (mut pairs, mut jumps) = (0usize, 0usize);
    for &i in &lit {
        if lit.contains(&(i + 1)) && (i + 1) % wd != 0 {
            pairs += 1;
            if (img.visibility[i] - img.visibility[i + 1]).abs() > 0.1 {
                jumps += 1;
            }
        }
    }
    eprintln!(
        "{jumps} jumps over {pairs} pairs, {dark} dark of {}",
        lit.len()
    );
    assert!(dark > 1000, "the plate's penumbra covers {dark} pixels");
    assert!(jumps * 20 < pairs, "{jumps} jumps > 0.1 over {pairs} pairs");
}
