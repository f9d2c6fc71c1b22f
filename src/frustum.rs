//! Light and camera math: the light frustum fitted to what the light sees, the camera's
//! view-projection, the light radius's range and the depth bias derived from the light's
//! depth span.

use crate::scene::{LightView, Scene};
use anyhow::{bail, Result};
use glam::{Mat4, Vec3};

/// The camera's view-projection for a `width` x `height` image, y flipped so that row 0 of
/// the image is the top (Vulkan's framebuffer y points down).
pub fn camera_view_proj(scene: &Scene, width: u32, height: u32) -> Mat4 {
    let cam = &scene.camera;
    let view = Mat4::look_at_rh(cam.position, cam.target, cam.up);
    let b = scene.bounds();
    let radius = (b.max - b.min).length() * 0.5;
    let dist = (cam.position - (b.min + b.max) * 0.5).length();
    let mut far = (dist + radius) * 1.05;
    let mut near = (dist - radius).max(far * 1e-4);
    // The bounding sphere's range clips what the camera sees when the scene is far larger
    // than the view (one object far away): then fit to the objects inside the view pyramid.
    let aspect = width as f32 / height as f32;
    let tan_v = (cam.fov_deg.to_radians() * 0.5).tan();
    let seen = scene
        .objects
        .iter()
        .filter_map(|o| clipped_depth_range(&o.world_bounds(), view, Some(tan_v * aspect.max(1.0))))
        .reduce(|(a, b), (c, d)| (a.min(c), b.max(d)));
    if let Some((lo, hi)) = seen {
        if lo * 0.99 < near || hi * 1.01 > far {
            far = hi * 1.01;
            near = (lo * 0.99).max(far * 1e-5);
        }
    }
    let mut proj = Mat4::perspective_rh(
        cam.fov_deg.to_radians(),
        width as f32 / height as f32,
        near,
        far,
    );
    proj.y_axis.y = -proj.y_axis.y;
    proj * view
}

/// The light frustum with near/far fitted for depth precision: `far` to what the light
/// actually sees (each object's world bounds clipped to the light's side planes and to
/// depth > 0), `near` to that and to every caster in front of the light, seen or not (a
/// caster just outside the cone still throws a penumbra into it; cutting it at `near` would
/// drop its silhouette). 1 % outside on each side. A large receiver whose lit part is small
/// and anything behind the light add nothing. Near is never closer than far * 1e-4 (also
/// when the light sits inside a bounding box); with nothing in the cone the whole scene's
/// bounds are used.
pub fn fit_light(scene: &Scene) -> LightView {
    let probe = LightView::new(&scene.light, 1.0, 2.0);
    let tan_half = (scene.light.fov_deg.to_radians() * 0.5).tan();
    let mut range: Option<(f32, f32)> = None;
    let mut caster_near = f32::MAX;
    for o in &scene.objects {
        let b = o.world_bounds();
        if b.is_empty() {
            continue;
        }
        if let Some((lo, hi)) = clipped_depth_range(&b, probe.view, Some(tan_half)) {
            range = Some(range.map_or((lo, hi), |(a, c)| (a.min(lo), c.max(hi))));
        }
        if o.role.casts() {
            // The nearest in-front depth of the box: only the depth plane clips.
            if let Some((lo, _)) = clipped_depth_range(&b, probe.view, None) {
                caster_near = caster_near.min(lo);
            }
        }
    }
    let range = range.map(|(lo, hi)| (lo.min(caster_near), hi));
    let (lo, hi) = range.unwrap_or_else(|| {
        let b = scene.bounds();
        b.corners()
            .iter()
            .map(|&c| probe.linear_depth(c))
            .fold((f32::MAX, f32::MIN), |(lo, hi), d| (lo.min(d), hi.max(d)))
    });
    let far = (hi * 1.01).max(1e-6);
    let near = (lo * 0.99).max(far * 1e-4);
    let mut view = LightView::new(&scene.light, near, far);
    view.depth_span = (hi - lo).clamp(0.0, far - near);
    view
}

/// World bounds of the objects inside the light's cone (the whole scene's when none is): the
/// scale of what the light's shadows are made of.
pub fn light_seen_bounds(scene: &Scene) -> crate::scene::Aabb {
    let probe = LightView::new(&scene.light, 1.0, 2.0);
    let tan_half = (scene.light.fov_deg.to_radians() * 0.5).tan();
    let seen = scene
        .objects
        .iter()
        .map(|o| o.world_bounds())
        .filter(|b| !b.is_empty() && clipped_depth_range(b, probe.view, Some(tan_half)).is_some())
        .fold(crate::scene::Aabb::EMPTY, |a, b| a.union(b));
    if seen.is_empty() {
        scene.bounds()
    } else {
        seen
    }
}

/// Linear-depth range of the part of box `b` inside the infinite light pyramid
/// (|x|, |y| <= tan_half * depth, depth > 0, in light view space), or `None` when the box
/// misses it. Exact for the box: each face is clipped as a polygon (Sutherland-Hodgman).
fn clipped_depth_range(
    b: &crate::scene::Aabb,
    view: Mat4,
    tan_half: Option<f32>,
) -> Option<(f32, f32)> {
    let c = b.corners().map(|p| view.transform_point3(p));
    // Faces of the box as corner-index quads (corner i has bit 0: x, bit 1: y, bit 2: z).
    const FACES: [[usize; 4]; 6] = [
        [0, 2, 6, 4],
        [1, 3, 7, 5],
        [0, 1, 5, 4],
        [2, 3, 7, 6],
        [0, 1, 3, 2],
        [4, 5, 7, 6],
    ];
    // Inside when plane(p) >= 0; depth = -z. The depth plane keeps a sliver in front of the
    // light so that a box around the light still yields a positive near.
    // Without `tan_half`, only the depth plane: the whole half-space in front of the light.
    let t = tan_half.unwrap_or(0.0);
    let sides: [&dyn Fn(Vec3) -> f32; 4] = [
        &|p: Vec3| -p.z * t - p.x,
        &|p: Vec3| -p.z * t + p.x,
        &|p: Vec3| -p.z * t - p.y,
        &|p: Vec3| -p.z * t + p.y,
    ];
    let depth_plane: &dyn Fn(Vec3) -> f32 = &|p: Vec3| -p.z;
    let mut planes = vec![depth_plane];
    if tan_half.is_some() {
        planes.extend(sides);
    }
    let mut range: Option<(f32, f32)> = None;
    for face in FACES {
        let mut poly: Vec<Vec3> = face.iter().map(|&i| c[i]).collect();
        for plane in &planes {
            let mut out = Vec::with_capacity(poly.len() + 2);
            for (i, &p) in poly.iter().enumerate() {
                let q = poly[(i + 1) % poly.len()];
                let (dp, dq) = (plane(p), plane(q));
                if dp >= 0.0 {
                    out.push(p);
                }
                if (dp >= 0.0) != (dq >= 0.0) {
                    out.push(p + (q - p) * (dp / (dp - dq)));
                }
            }
            poly = out;
            if poly.is_empty() {
                break;
            }
        }
        for p in poly {
            let d = -p.z;
            if d.is_finite() {
                range = Some(range.map_or((d, d), |(lo, hi)| (lo.min(d), hi.max(d))));
            }
        }
    }
    // The clipped faces miss one vertex of the box-pyramid intersection: the light itself,
    // when it sits inside the box.
    let light = view.inverse().transform_point3(Vec3::ZERO);
    if let Some((lo, _)) = range.as_mut() {
        if (b.min.cmple(light) & light.cmple(b.max)).all() {
            *lo = 0.0;
        }
    }
    // A box that only touches the apex leaves depth 0: no usable range from it.
    range.filter(|&(_, hi)| hi > 0.0)
}

/// Largest light radius, in bounding radii of the scene (README "Numeric range").
pub const MAX_RADIUS_SCENES: f32 = 100.0;

/// Refuses a light radius above `MAX_RADIUS_SCENES` scene radii: such a light sees every
/// receiver alike and the f32 penumbra estimates of the techniques overflow their clamps. The
/// `Ok` value is a warning for a light sphere that reaches a caster, which no fake technique
/// models (they assume the casters are outside the light).
pub fn check_radius(scene: &Scene, radius: f32) -> Result<Option<String>> {
    let size = scene.bounds().radius();
    let max = MAX_RADIUS_SCENES * size;
    if radius > max {
        bail!("light radius {radius} is out of range: allowed 0..={max} ({MAX_RADIUS_SCENES} x the scene's bounding radius {size})");
    }
    let p = scene.light.position;
    let nearest = scene
        .objects
        .iter()
        .filter(|o| o.role.casts())
        .map(|o| {
            let b = o.world_bounds();
            (p.clamp(b.min, b.max) - p).length()
        })
        .fold(f32::INFINITY, f32::min);
    Ok((radius > nearest).then(|| {
        format!("warning: light radius {radius} reaches a caster ({nearest} from the light): the fake techniques assume casters outside the light and will differ from the reference")
    }))
}

/// The relative depth bias the shaders apply (`stored * (1 + bias)`): `depth_bias` of the
/// depth, but at most `depth_bias` x 4 x the depth span the light sees (`LightView::depth_span`)
/// at the far plane. A light far from a compact scene (span << far) would otherwise get an
/// absolute bias larger than the scene's contact gaps and objects. Never below 8 ulps, the
/// rounding of a stored depth.
pub fn effective_depth_bias(depth_bias: f32, depth_span: f32, far: f32) -> f32 {
    let span = (depth_span / far.max(f32::MIN_POSITIVE)).clamp(0.0, 1.0);
    (depth_bias * (4.0 * span).min(1.0)).max(8.0 * f32::EPSILON)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::Aabb;

    fn view_down_z() -> Mat4 {
        // Light at the origin looking down -z: view space = world space.
        Mat4::IDENTITY
    }

    #[test]
    fn clipped_range_of_a_box_inside_the_cone_is_its_depth_range() {
        let b = Aabb::new(Vec3::new(-0.1, -0.1, -3.0), Vec3::new(0.1, 0.1, -2.0));
        let (lo, hi) = clipped_depth_range(&b, view_down_z(), Some(1.0)).unwrap();
        assert!(
            (lo - 2.0).abs() < 1e-6 && (hi - 3.0).abs() < 1e-6,
            "{lo} {hi}"
        );
    }

    #[test]
    fn a_box_outside_the_cone_or_behind_the_light_gives_nothing() {
        let beside = Aabb::new(Vec3::new(10.0, -0.1, -3.0), Vec3::new(11.0, 0.1, -2.0));
        assert_eq!(clipped_depth_range(&beside, view_down_z(), Some(1.0)), None);
        // ... but in front of the light: a caster there still counts for `near`.
        let (lo, _) = clipped_depth_range(&beside, view_down_z(), None).unwrap();
        assert!((lo - 2.0).abs() < 1e-6, "{lo}");
        let behind = Aabb::new(Vec3::new(-1.0, -1.0, 2.0), Vec3::new(1.0, 1.0, 3.0));
        assert_eq!(clipped_depth_range(&behind, view_down_z(), Some(1.0)), None);
    }

    #[test]
    fn a_huge_ground_is_clipped_to_the_cone() {
        // A plane 100 wide at depth ~5 seen through a 90-degree cone: only |x|,|y| <= 5 of it
        // is lit, and a tilt of the plane makes its far corners much deeper than what is seen.
        let ground = Aabb::new(
            Vec3::new(-100.0, -100.0, -5.0),
            Vec3::new(100.0, 100.0, -4.0),
        );
        let (lo, hi) = clipped_depth_range(&ground, view_down_z(), Some(1.0)).unwrap();
        assert!(
            (lo - 4.0).abs() < 1e-5 && (hi - 5.0).abs() < 1e-5,
            "{lo} {hi}"
        );
        // A box around the light: the range starts at the light.
        let around = Aabb::new(Vec3::splat(-1.0), Vec3::splat(1.0));
        let (lo, hi) = clipped_depth_range(&around, view_down_z(), Some(1.0)).unwrap();
        assert!(lo.abs() < 1e-6 && (hi - 1.0).abs() < 1e-6, "{lo} {hi}");
    }

    #[test]
    fn fit_light_ignores_objects_the_light_cannot_see() {
        let mut scene = Scene::load("cylinder").unwrap();
        let before = fit_light(&scene);
        let mut far_away = scene.objects[0].clone();
        far_away.name = "far away".into();
        // Far behind the light: a fit to the whole scene's bounds would push `far` out to it.
        let back = (scene.light.position - scene.light.target).normalize() * 1000.0;
        far_away.transform = Mat4::from_translation(scene.light.position + back);
        scene.objects.push(far_away);
        let after = fit_light(&scene);
        assert_eq!((before.near, before.far), (after.near, after.far));
        assert!(after.far < 100.0, "far {}", after.far);
    }
}
