//! plateaus (Haines 2001): lit and umbra agree with `hard`, the penumbra hardens towards the
//! contact, a point light reproduces `hard` on the plane, and a scene without a planar
//! receiver is refused with a clear error.

mod common;

use common::{covered, pixel_at, small, Gpu};
use glam::{Mat4, Vec2, Vec3, Vec4};
use softshadow::output::FrameImages;
use softshadow::render::Renderer;
use softshadow::scene::{primitives, Camera, Light, Object, Role, Scene};
use std::sync::Arc;

fn vis_at(img: &FrameImages, p: Vec3) -> f32 {
    let i = pixel_at(img, p);
    let got = Vec4::from(img.position[i]).truncate();
    assert!(
        (got - p).length() < 0.1,
        "no pixel near {p} (nearest {got})"
    );
    img.visibility[i]
}

/// Cylinder scene: light at (-6, 5, 1), cylinder of radius 0.5 and height 2 at the origin;
/// the shadow runs from the cylinder away from the light's foot (-6, 0, 1).
fn shadow_axis() -> (Vec2, Vec2) {
    let along = Vec2::new(6.0, -1.0).normalize();
    (along, along.perp())
}

#[test]
fn lit_and_umbra_agree_with_hard() {
    let gpu = Gpu::new();
    let plateaus = gpu.render("cylinder", "plateaus", small(160, 256));
    let hard = gpu.render("cylinder", "hard", small(160, 256));
    let (along, side) = shadow_axis();
    let ground = |a: f32, s: f32| {
        let q = along * a + side * s;
        Vec3::new(q.x, 0.0, q.y)
    };
    let n = Vec3::new(1.0, 0.0, 1.0).normalize() * 0.5;
    for (what, p, want) in [
        ("ground in the deep umbra", ground(1.5, 0.0), 0.0),
        (
            "ground in the umbra far from the cylinder",
            ground(3.0, 0.0),
            0.0,
        ),
        ("lit ground beside the shadow", ground(1.5, 1.6), 1.0),
        (
            "lit ground in front of the cylinder",
            ground(-1.5, 0.0),
            1.0,
        ),
        // Receivers off the plane get the shadow map: the cylinder's own unlit side.
        ("the cylinder's unlit side", Vec3::new(n.x, 1.0, n.z), 0.0),
    ] {
        let (vp, vh) = (vis_at(&plateaus, p), vis_at(&hard, p));
        assert!(
            (vp - want).abs() < 1e-3,
            "{what} at {p}: plateaus {vp}, want {want}"
        );
        assert!(
            (vh - want).abs() < 1e-3,
            "{what} at {p}: hard {vh}, want {want}"
        );
    }
    for v in &plateaus.visibility {
        assert!(
            v.is_finite() && (0.0..=1.0).contains(v),
            "visibility {v} out of [0,1]"
        );
    }
}

/// World width (across the shadow) of the penumbra on one side of the cylinder's shadow, in a
/// slab of the ground `a0..a1` along the shadow: the lateral spread of penumbra pixels.
fn penumbra_width(img: &FrameImages, a0: f32, a1: f32) -> f32 {
    let (along, side) = shadow_axis();
    let mut lo = f32::MAX;
    let mut hi = f32::MIN;
    for i in covered(img) {
        let p = Vec4::from(img.position[i]).truncate();
        if p.y.abs() > 1e-3 {
            continue;
        }
        let q = Vec2::new(p.x, p.z);
        let (a, s) = (q.dot(along), q.dot(side));
        let v = img.visibility[i];
        // The +side half only: both penumbrae together would measure the shadow's width.
        if a < a0 || a > a1 || s < 0.0 || !(0.02..=0.98).contains(&v) {
            continue;
        }
        lo = lo.min(s);
        hi = hi.max(s);
    }
    if hi < lo {
        0.0
    } else {
        hi - lo
    }
}

#[test]
fn contact_hardening_on_cylinder() {
    let gpu = Gpu::new();
    let mut settings = small(256, 512);
    settings.light_radius = Some(1.0);
    let img = gpu.render("cylinder", "plateaus", settings.clone());
    // Silhouette heights ~0.7 near the base, ~1.8 far away: cone radii R h / (H - h) of
    // about 0.16 and 0.58.
    let near = penumbra_width(&img, 0.9, 1.1);
    let far = penumbra_width(&img, 3.4, 3.6);
    eprintln!("penumbra width near {near}, far {far}");
    assert!(far > 0.3, "far penumbra {far} too narrow for R = 1");
    assert!(
        far > 2.5 * near,
        "no contact hardening: near {near}, far {far}"
    );
    // With R = 0 both collapse to the hard edge (a pixel or two of filtering).
    settings.light_radius = Some(0.0);
    let hard_like = gpu.render("cylinder", "plateaus", settings);
    let far0 = penumbra_width(&hard_like, 3.4, 3.6);
    eprintln!("R = 0: far {far0}");
    assert!(far0 < far / 4.0, "R = 0 still has a {far0} wide penumbra");
}

#[test]
fn point_light_matches_hard_on_the_plane() {
    let gpu = Gpu::new();
    let mut settings = small(192, 512);
    settings.light_radius = Some(0.0);
    let scene = Scene::load("cylinder").unwrap_or_else(|e| panic!("{e:#}"));
    let (plateaus, timings) = gpu.render_frames(scene, "plateaus", settings.clone(), 1);
    let hard = gpu.render("cylinder", "hard", settings);
    let t = &timings[0];
    assert!(
        t.passes
            .iter()
            .any(|p| p.name == "plateaus/plateaus" && p.not_run.is_some()),
        "R = 0 must leave the plateau pass out"
    );
    let (w, h) = (hard.width as usize, hard.height as usize);
    let on_ground = |i: usize| hard.position[i][3] > 0.5 && hard.position[i][1].abs() < 1e-3;
    let (mut compared, mut shadowed, mut differ) = (0usize, 0usize, 0usize);
    for y in 2..h - 2 {
        for x in 2..w - 2 {
            let i = y * w + x;
            if !on_ground(i) {
                continue;
            }
            // Away from edges: the hard result is the same over the 5x5 neighbourhood.
            let v = hard.visibility[i];
            let uniform = (0..25).all(|k| {
                let j = (y + k / 5 - 2) * w + (x + k % 5 - 2);
                on_ground(j) && (hard.visibility[j] - v).abs() < 1e-3
            });
            if !uniform {
                continue;
            }
            compared += 1;
            shadowed += usize::from(v < 0.5);
            differ += usize::from((plateaus.visibility[i] - v).abs() > 1e-3);
        }
    }
    eprintln!("{differ} of {compared} differ, {shadowed} in umbra");
    assert!(shadowed > 300, "only {shadowed} umbra pixels compared");
    assert!(
        (differ as f32) < 0.002 * compared as f32,
        "{differ} of {compared} ground pixels differ from hard"
    );
}

#[test]
fn scene_without_planar_receiver_is_refused() {
    let gpu = Gpu::new();
    let ball = Arc::new(primitives::sphere(1.0, 24, 12));
    let scene = Scene {
        name: "balls".into(),
        objects: vec![
            Object::new(
                "receiver",
                ball.clone(),
                Mat4::IDENTITY,
                Role::Receiver,
                Vec3::ONE,
            ),
            Object::new(
                "caster",
                ball,
                Mat4::from_translation(Vec3::new(0.0, 2.5, 0.0))
                    * Mat4::from_scale(Vec3::splat(0.4)),
                Role::Caster,
                Vec3::ONE,
            ),
        ],
        light: Light {
            position: Vec3::new(0.0, 6.0, 0.0),
            target: Vec3::ZERO,
            fov_deg: 50.0,
            radius: 0.3,
            kind: softshadow::scene::LightKind::Spot,
        },
        camera: Camera {
            position: Vec3::new(0.0, 3.0, 6.0),
            target: Vec3::ZERO,
            up: Vec3::Y,
            fov_deg: 45.0,
        },
    };
    let err = match Renderer::new(&gpu.ctx, scene.clone(), "plateaus", small(64, 64)) {
        Ok(_) => panic!("plateaus accepted a scene without a planar receiver"),
        Err(e) => format!("{e:#}"),
    };
    assert!(
        err.contains("planar receiver") && err.contains("balls"),
        "{err}"
    );
    // The same scene is fine for techniques that need no plane.
    assert!(Renderer::new(&gpu.ctx, scene, "hard", small(64, 64)).is_ok());
}

#[test]
fn caster_lying_in_the_plane_is_lit() {
    // Stress case `caster-on-receiver`: a flat sheet exactly in the ground plane (it IS the
    // receiver surface there) beside a box resting on the ground. A drop shadow drawn at
    // height 0 would make the sheet its own umbra.
    let gpu = Gpu::new();
    let obj = |name: &str, mesh, at: Vec3| {
        Object::new(
            name,
            Arc::new(mesh),
            Mat4::from_translation(at),
            Role::Both,
            Vec3::splat(0.7),
        )
    };
    let scene = Scene {
        name: "coplanar".into(),
        objects: vec![
            Object::new(
                "ground",
                Arc::new(primitives::plane(Vec2::splat(12.0), 8)),
                Mat4::IDENTITY,
                Role::Receiver,
                Vec3::splat(0.8),
            ),
            obj(
                "box",
                primitives::cuboid(Vec3::ONE),
                Vec3::new(-1.0, 0.5, 0.0),
            ),
            obj(
                "sheet",
                primitives::plane(Vec2::splat(1.5), 1),
                Vec3::new(1.2, 0.0, 0.5),
            ),
        ],
        light: Light {
            position: Vec3::new(-3.0, 7.0, 2.0),
            target: Vec3::ZERO,
            fov_deg: 60.0,
            radius: 0.3,
            kind: softshadow::scene::LightKind::Spot,
        },
        camera: Camera {
            position: Vec3::new(1.0, 6.0, 6.0),
            target: Vec3::new(0.5, 0.0, 0.3),
            up: Vec3::Y,
            fov_deg: 50.0,
        },
    };
    let (img, _) = gpu.render_frames(scene, "plateaus", small(128, 256), 1);
    // The sheet's inner part (0.1 from its edges) and the box's shadow behind it.
    let mut n = 0;
    for i in covered(&img) {
        let p = Vec4::from(img.position[i]).truncate();
        if p.y.abs() < 1e-3 && (p.x - 1.2).abs() < 0.65 && (p.z - 0.5).abs() < 0.65 {
            n += 1;
            assert_eq!(img.visibility[i], 1.0, "sheet point {p}");
        }
    }
    assert!(n > 100, "{n} sheet pixels");
    let shadow = vis_at(&img, Vec3::new(-0.25, 0.0, -0.7));
    assert!(shadow < 0.01, "the box still shadows the ground: {shadow}");
}
