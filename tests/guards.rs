//! The shaders' contact guards, tested through the shaders: a scene that drives them to
//! their edge is rendered by every technique and the visibility read back.
//!
//! - penumbra-map's `CONTACT_EPS` (glsl/penumbra_map/wedge.glsl, `eq1_depths`): a cone or
//!   sheet fragment whose surface lies at (or in front of) its silhouette vertex, Z_P - Z_v
//!   below 1e-4 Z_P, is discarded. Without it Eq. 1 divides a rounding error by a rounding
//!   error and speckles the caster's own lit top and the ground at a contact.
//! - smoothies' `REMAP_EPS` (glsl/smoothies/alpha.glsl, `smoothie_alpha`): a smoothie within 1e-4 of the
//!   depth it shades touches it and casts nothing (the fragment is discarded).
//! - pcss's no-blocker return (glsl/pcss/final.frag, `blockers == 0.0`): the mean blocker
//!   depth is formed only when the search found one; without it 0/0 darkens every lit pixel
//!   near the box (this test fails: all 56 ground pixels beside it below 0.9).
//!
//! What these guards change does not reach a pixel today (issue 27, shown by mutation):
//! - deleting penumbra-map's guard (`eq1_depths` returning true) leaves the read-back
//!   `penumbra_map` buffer bit-identical on cylinder, boxes, overlap, fence, bunny and
//!   primitives, the visibility bit-identical on every built-in scene and on this one (5 light
//!   positions x 6 sizes), and every stress row the same: the fragments it drops lie within a
//!   rounding error of their own silhouette vertex, where a penumbra has no width, and
//!   rasterise to no texel;
//! - setting smoothies' guarded value to 0 (a touching smoothie casts full shadow; measured
//!   when the guard wrote alpha' = 1, before it discarded) changes no pixel either, even for the sheet hovering at 1 - b/r = 1.4e-5: the final pass's depth
//!   bias (5e-4 relative) already ignores a smoothie that close.
//!
//! So this test cannot fail for those two deletions (tests/shader_guards.rs runs the guarded
//! GLSL functions themselves and does); it pins what they are for (contacts and casters in
//! the receiver's plane stay lit, for every technique) and fails for the guards that do
//! reach pixels here: pcss's, and plateaus' on-plane discard (glsl/plateaus/drop_shadow.frag).
//!
//! The scene: a box resting on the ground, a sheet lying exactly in the ground plane (the
//! stress case `caster-on-receiver`) and one hovering 1e-4 above it, a light above and to the
//! side. What must hold, whatever
//! the technique: the box's top faces the light with nothing above it (lit); the sheet and a
//! ring of ground around it are lit (a caster in the receiver's plane hides no light), and so
//! are the hovering sheet and its ring (its penumbra is 1e-5 wide); the
//! ground beside the box's lit sides is lit (a contact has no penumbra on the light's side).

mod common;
use common::{covered, small, Gpu};
use glam::{Mat4, Vec2, Vec3, Vec4};
use softshadow::output::FrameImages;
use softshadow::scene::primitives as prim;
use softshadow::scene::{Camera, Light, Object, Role, Scene};
use softshadow::settings::Settings;
use softshadow::technique::TECHNIQUES;
use std::sync::Arc;

const BOX_AT: Vec3 = Vec3::new(-1.0, 0.5, 0.0);
const SHEET_AT: Vec3 = Vec3::new(2.0, 0.0, 0.5);
const SHEET_HALF: f32 = 0.75;
/// A second sheet hovering 1e-4 above the ground: 1 - b/r ~ 1.4e-5 seen from the light,
/// below both guards' 1e-4.
const HOVER_AT: Vec3 = Vec3::new(2.0, 1e-4, -1.6);

fn contact_scene() -> Scene {
    let albedo = Vec3::splat(0.7);
    let ground = prim::plane(Vec2::splat(12.0), 8);
    let cube = prim::cuboid(Vec3::ONE);
    let sheet = prim::plane(Vec2::splat(2.0 * SHEET_HALF), 1);
    Scene {
        name: "contact".into(),
        objects: vec![
            Object::new(
                "ground",
                Arc::new(ground),
                Mat4::IDENTITY,
                Role::Receiver,
                albedo,
            ),
            Object::new(
                "box",
                Arc::new(cube),
                Mat4::from_translation(BOX_AT),
                Role::Both,
                albedo,
            ),
            // Exactly coplanar with the ground (y = 0).
            Object::new(
                "sheet",
                Arc::new(sheet.clone()),
                Mat4::from_translation(SHEET_AT),
                Role::Both,
                albedo,
            ),
            Object::new(
                "hovering sheet",
                Arc::new(sheet),
                Mat4::from_translation(HOVER_AT),
                Role::Both,
                albedo,
            ),
        ],
        light: Light {
            position: Vec3::new(-3.0, 7.0, 2.0),
            target: Vec3::new(0.5, 0.0, 0.3),
            fov_deg: 70.0,
            radius: 0.25,
            kind: softshadow::scene::LightKind::Spot,
        },
        camera: Camera {
            position: Vec3::new(0.5, 6.0, 6.0),
            target: Vec3::new(0.5, 0.0, 0.3),
            up: Vec3::Y,
            fov_deg: 50.0,
        },
    }
}

fn settings() -> Settings {
    Settings {
        occluder_res: 256,
        ..small(128, 512)
    }
}

fn pos(img: &FrameImages, i: usize) -> Vec3 {
    Vec4::from(img.position[i]).truncate()
}

/// Distance in the ground plane from `p` to the square of the sheet at `at` (0 inside).
fn off_sheet(p: Vec3, at: Vec3) -> f32 {
    let d = (Vec2::new(p.x - at.x, p.z - at.z)).abs() - Vec2::splat(SHEET_HALF);
    d.max(Vec2::ZERO).length()
}

/// The regions that must be lit, as pixel lists: the box's top, the sheet with the ground
/// within 0.4 of it, and the ground within 0.03 .. 0.3 of the box's two light-facing sides
/// (x = -1.5 and z = 0.5).
fn lit_regions(img: &FrameImages) -> Vec<(&'static str, Vec<usize>)> {
    let cov = covered(img);
    let top: Vec<usize> = cov
        .iter()
        .copied()
        .filter(|&i| {
            let p = pos(img, i);
            (p.y - 1.0).abs() < 1e-3
                && (p.x - BOX_AT.x).abs() < 0.45
                && (p.z - BOX_AT.z).abs() < 0.45
        })
        .collect();
    let sheet: Vec<usize> = cov
        .iter()
        .copied()
        .filter(|&i| {
            let p = pos(img, i);
            p.y.abs() < 1e-3 && off_sheet(p, SHEET_AT) < 0.4
        })
        .collect();
    let hovering: Vec<usize> = cov
        .iter()
        .copied()
        .filter(|&i| {
            let p = pos(img, i);
            p.y.abs() < 1e-3 && off_sheet(p, HOVER_AT) < 0.4
        })
        .collect();
    let beside: Vec<usize> = cov
        .iter()
        .copied()
        .filter(|&i| {
            let p = pos(img, i);
            let dx = BOX_AT.x - 0.5 - p.x;
            let dz = p.z - (BOX_AT.z + 0.5);
            p.y.abs() < 1e-3
                && ((0.03..0.3).contains(&dx) && (p.z - BOX_AT.z).abs() < 0.4
                    || (0.03..0.3).contains(&dz) && (p.x - BOX_AT.x).abs() < 0.4)
        })
        .collect();
    vec![
        ("the box's lit top", top),
        ("the sheet in the ground and the ground around it", sheet),
        ("the ground beside the box's lit sides", beside),
        ("the hovering sheet and the ground around it", hovering),
    ]
}

/// Every technique, the reference included: finite, in [0,1], and the regions that must be
/// lit are lit at every pixel (the darkest allowed is 0.9: measured, the darkest such pixel
/// of any technique is 1.0).
#[test]
fn contacts_and_a_caster_in_the_ground_plane_stay_lit() {
    let gpu = Gpu::new();
    let scene = contact_scene();
    scene.validate().unwrap();
    for t in TECHNIQUES.iter().map(|t| t.name) {
        let (img, _) = gpu.render_frames(scene.clone(), t, settings(), 1);
        for (i, v) in img.visibility.iter().enumerate() {
            assert!(
                v.is_finite() && (0.0..=1.0).contains(v),
                "{t}: pixel {i} = {v}"
            );
        }
        for (what, px) in lit_regions(&img) {
            assert!(px.len() >= 30, "{t}: only {} pixels of {what}", px.len());
            let dark: Vec<(Vec3, f32)> = px
                .iter()
                .filter(|&&i| img.visibility[i] < 0.9)
                .map(|&i| (pos(&img, i), img.visibility[i]))
                .collect();
            let min = px.iter().map(|&i| img.visibility[i]).fold(1.0f32, f32::min);
            eprintln!(
                "{t}: {what}: {} pixels, darkest {min:.4}, {} below 0.9",
                px.len(),
                dark.len()
            );
            assert!(
                dark.is_empty(),
                "{t}: {} of {} pixels of {what} darker than 0.9, e.g. {:?}",
                dark.len(),
                px.len(),
                &dark[..dark.len().min(5)]
            );
        }
    }
}
