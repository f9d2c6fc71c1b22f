//! Light and camera math: the light frustum fitted to what the light sees, the camera's
//! view-projection, the light radius's range and the depth bias derived from the light's
//! depth span.

use crate::scene::{LightView, Scene};
use anyhow::{bail, Result};
use glam::{Mat3, Mat4, Vec2, Vec3, Vec4};

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

/// The light frustum. A spotlight's is fitted across its axis first (`spot_window`): a
/// square frustum inside the cone over what the camera sees lit and the penumbrae reaching
/// it, when that gains at least `SPOT_FIT_MIN_GAIN` texels per texel; else the whole cone.
/// Then near/far for depth precision: `far` to what the frustum actually sees (each object's
/// world bounds clipped to its side planes and to depth > 0), `near` to that and to every
/// caster in front of the light, seen or not (a caster just outside the frustum still throws
/// a penumbra into it; cutting it at `near` would drop its silhouette). 1 % outside on each
/// side. A large receiver whose lit part is small and anything behind the light add nothing.
/// Near is never closer than far * 1e-4 (also when the light sits inside a bounding box);
/// with nothing in the frustum the whole scene's bounds are used.
pub fn fit_light(scene: &Scene) -> LightView {
    if scene.light.is_sun() {
        return fit_sun(scene);
    }
    let cone = LightView::new(&scene.light, 1.0, 2.0);
    let tan_cone = (scene.light.fov_deg.to_radians() * 0.5).tan();
    let fitted = spot_window(scene, &cone, tan_cone).and_then(|(lo, hi)| {
        // The square frustum around the window's centre ray holding its four corner rays
        // holds the whole window (a convex set of rays), 1 % outside.
        let to_world = Mat3::from_mat4(cone.view).transpose();
        let ray = |t: Vec2| to_world * t.extend(-1.0);
        let dir = ray((lo + hi) * 0.5).normalize();
        let up = to_world * Vec3::Y;
        let view = Mat4::look_to_rh(Vec3::ZERO, dir, up);
        let tan_half = [lo, Vec2::new(lo.x, hi.y), Vec2::new(hi.x, lo.y), hi]
            .into_iter()
            .map(|c| {
                let v = view.transform_vector3(ray(c));
                v.x.abs().max(v.y.abs()) / -v.z
            })
            .fold(0.0f32, f32::max)
            * 1.01;
        (tan_half.is_finite() && tan_half * SPOT_FIT_MIN_GAIN <= tan_cone)
            .then_some((dir, up, tan_half))
    });
    let frame = |near: f32, far: f32| match fitted {
        Some((dir, up, t)) => LightView::fitted(&scene.light, dir, up, t, near, far),
        None => LightView::new(&scene.light, near, far),
    };
    let probe = frame(1.0, 2.0);
    let tan_half = (probe.fov_deg.to_radians() * 0.5).tan();
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
    let mut view = frame(near, far);
    view.depth_span = (hi - lo).clamp(0.0, far - near);
    view
}

/// A spotlight's map is fitted inside its cone only when the fitted frustum is at most
/// 1 / this as wide (this many times the texels along each side on what matters): a smaller
/// gain is not worth a map that moves with the camera.
pub const SPOT_FIT_MIN_GAIN: f32 = 2.0;

/// The part of a spotlight's cone that matters, as a rectangle lo..hi of (x, y) / depth in
/// the cone's frame (`cone`, half-width `tan_cone`): every receiver's part inside the
/// camera's frustum (for an image up to `SUN_FIT_ASPECT` wide) and the cone, grown by the
/// widest penumbra reaching it, R (1 / b - 1 / r) for the nearest caster depth b over the
/// rectangle (casters outside the view shadow what is in it) and the farthest seen receiver
/// depth r; clamped to the cone. `None` when the camera sees no lit receiver.
fn spot_window(scene: &Scene, cone: &LightView, tan_cone: f32) -> Option<(Vec2, Vec2)> {
    let t = tan_cone;
    // The cone's side planes and depth > 0, as world planes (a view-space plane q holds
    // view p where q . p >= 0; q . (V p) = (V^T q) . p).
    let to_world = cone.view.transpose();
    let cone_planes = [
        Vec4::new(-1.0, 0.0, -t, 0.0),
        Vec4::new(1.0, 0.0, -t, 0.0),
        Vec4::new(0.0, -1.0, -t, 0.0),
        Vec4::new(0.0, 1.0, -t, 0.0),
        Vec4::new(0.0, 0.0, -1.0, 0.0),
    ]
    .map(|q| to_world * q);
    let cam = camera_view_proj(scene, (SUN_FIT_ASPECT * 1000.0) as u32, 1000);
    let (r0, r1, r2, r3) = (cam.row(0), cam.row(1), cam.row(2), cam.row(3));
    let cam_planes = [r3 + r0, r3 - r0, r3 + r1, r3 - r1, r2, r3 - r2];
    // (x / depth, y / depth, depth) in the cone's frame of the part of `b` inside `planes`.
    let cut = |b: &crate::scene::Aabb, planes: &[Vec4]| -> Vec<Vec3> {
        let mut p = Polytope::hexahedron(&b.corners());
        for &q in planes {
            p.clip(q);
        }
        p.vertices()
            .map(|&v| {
                let q = cone.view.transform_point3(v);
                let d = -q.z;
                Vec3::new(q.x / d, q.y / d, d)
            })
            .filter(|q| q.is_finite() && q.z > 0.0)
            .collect()
    };
    let seen: Vec<Vec3> = scene
        .objects
        .iter()
        .filter(|o| o.role.receives())
        .flat_map(|o| {
            let planes: Vec<Vec4> = cam_planes.iter().chain(&cone_planes).copied().collect();
            cut(&o.world_bounds(), &planes)
        })
        .collect();
    if seen.is_empty() {
        return None;
    }
    let lo = seen.iter().fold(Vec3::INFINITY, |a, &q| a.min(q));
    let hi = seen.iter().fold(Vec3::NEG_INFINITY, |a, &q| a.max(q));
    let far_seen = hi.z;
    let (lo, hi) = (
        lo.truncate().max(Vec2::splat(-t)),
        hi.truncate().min(Vec2::splat(t)),
    );
    let casters: Vec<Vec<Vec3>> = scene
        .objects
        .iter()
        .filter(|o| o.role.casts())
        .map(|o| cut(&o.world_bounds(), &cone_planes))
        .filter(|c| !c.is_empty())
        .collect();
    let radius = scene.light.radius.max(0.0);
    let reach = |b: f32| (radius * (1.0 / b - 1.0 / far_seen)).max(0.0);
    let mut nearest = f32::INFINITY;
    for _ in 0..2 {
        let m = if nearest.is_finite() {
            reach(nearest)
        } else {
            0.0
        };
        for c in &casters {
            let clo = c.iter().fold(Vec3::INFINITY, |a, &q| a.min(q));
            let chi = c.iter().fold(Vec3::NEG_INFINITY, |a, &q| a.max(q));
            let overlaps =
                clo.x <= hi.x + m && chi.x >= lo.x - m && clo.y <= hi.y + m && chi.y >= lo.y - m;
            if overlaps && clo.z < far_seen {
                nearest = nearest.min(clo.z);
            }
        }
    }
    let m = if nearest.is_finite() {
        reach(nearest) * 1.01
    } else {
        0.0
    };
    let lo = (lo - Vec2::splat(m)).max(Vec2::splat(-t));
    let hi = (hi + Vec2::splat(m)).min(Vec2::splat(t));
    // A window a hair wide (a receiver seen edge-on) still gets a frustum around it.
    let pad = Vec2::splat(t * 1e-3);
    (lo.cmple(hi).all()).then_some((lo - pad, hi + pad))
}

/// Casters whose shadow-map image is under `MIN_CASTER_TEXELS` texels across (the widest
/// side of its bounds' light-uv box) in a side-`res` map of `light`: named in one warning
/// line saying what to change, or `None`. Casters outside the frustum or reaching behind the
/// light are not judged.
pub fn caster_texel_warning(scene: &Scene, light: &LightView, res: u32) -> Option<String> {
    let mut small: Vec<(String, f32)> = Vec::new();
    for o in scene.objects.iter().filter(|o| o.role.casts()) {
        let b = o.world_bounds();
        if b.is_empty() {
            continue;
        }
        let corners = b.corners();
        let projected: Vec<(Vec2, f32)> = corners.iter().map(|&c| light.project(c)).collect();
        if projected
            .iter()
            .any(|(uv, d)| *d <= 0.0 || !d.is_finite() || !uv.is_finite())
        {
            continue;
        }
        let lo = projected
            .iter()
            .fold(Vec2::INFINITY, |a, (uv, _)| a.min(*uv));
        let hi = projected
            .iter()
            .fold(Vec2::NEG_INFINITY, |a, (uv, _)| a.max(*uv));
        let inside = lo.cmple(Vec2::ONE).all() && hi.cmpge(Vec2::ZERO).all();
        let texels = (hi - lo).max_element() * res as f32;
        if inside && texels < MIN_CASTER_TEXELS {
            small.push((o.name.clone(), texels));
        }
    }
    if small.is_empty() {
        return None;
    }
    let names: Vec<String> = small
        .iter()
        .take(3)
        .map(|(n, t)| format!("'{n}' ({t:.2} texels)"))
        .collect();
    let more = match small.len() {
        n if n > 3 => format!(" and {} more", n - 3),
        _ => String::new(),
    };
    let fix = if light.sun.is_some() {
        "narrow the camera's view or raise --shadow-res"
    } else {
        "narrow the light's cone, move the light closer or raise --shadow-res"
    };
    Some(format!(
        "warning: caster {}{more} spans fewer than {MIN_CASTER_TEXELS} texels of the {res}x{res} shadow map: its shadow may vanish; {fix}",
        names.join(", ")
    ))
}

/// Fewest texels a caster should span in the shadow map (`caster_texel_warning`): below
/// about two, a caster's shadow falls between texel centres and comes and goes.
pub const MIN_CASTER_TEXELS: f32 = 2.0;

/// Widest image a sun's map is fitted for (`fit_sun`): width / height up to this share the
/// camera's vertical field of view and see no more than it.
pub const SUN_FIT_ASPECT: f32 = 2.0;

/// A sun's orthographic map, fitted to what the camera sees: across the light's axis the
/// square over every receiver's part inside the camera's frustum (for an image up to
/// `SUN_FIT_ASPECT` wide), grown by the widest penumbra (tan theta x the depth range) so that
/// a blocker just outside still reaches in, 1 % outside; along the axis from the nearest
/// caster over that square to the farthest seen receiver. One map, no cascades: a view
/// reaching far from the camera spreads its texels thin. With no receiver in view the whole
/// scene is fitted. The eye sits half the depth range (at least 1e-3 scene radii) in front of
/// the nearest caster, so linear depths are positive and the relative depth bias keeps the
/// scale of the depth range.
fn fit_sun(scene: &Scene) -> LightView {
    let light = &scene.light;
    let dir = light.direction();
    let up = if dir.y.abs() > 0.99 { Vec3::Z } else { Vec3::Y };
    // Light space at the world origin: x, y across the axis, depth = -z.
    let probe = Mat4::look_to_rh(Vec3::ZERO, -dir, up);
    let cam = camera_view_proj(scene, (SUN_FIT_ASPECT * 1000.0) as u32, 1000);
    let (r0, r1, r2, r3) = (cam.row(0), cam.row(1), cam.row(2), cam.row(3));
    let planes = [r3 + r0, r3 - r0, r3 + r1, r3 - r1, r2, r3 - r2];
    // (x, y, depth) of world points.
    let light_space = |p: Vec3| {
        let q = probe.transform_point3(p);
        Vec3::new(q.x, q.y, -q.z)
    };
    let mut seen = Vec::new();
    for o in scene.objects.iter().filter(|o| o.role.receives()) {
        let mut cut = Polytope::hexahedron(&o.world_bounds().corners());
        for p in planes {
            cut.clip(p);
        }
        seen.extend(cut.vertices().map(|&p| light_space(p)));
    }
    seen.retain(|q| q.is_finite());
    if seen.is_empty() {
        seen.extend(scene.bounds().corners().map(light_space));
    }
    let lo = seen.iter().fold(Vec3::INFINITY, |a, &q| a.min(q));
    let hi = seen.iter().fold(Vec3::NEG_INFINITY, |a, &q| a.max(q));
    let radius = scene.bounds().radius().max(crate::scene::MIN_SCENE_RADIUS);
    let tan = light.sun_angle_deg().unwrap_or(0.0).to_radians().tan();
    // The casters over the receivers' square, with the widest penumbra's reach around it.
    let reach = |caster_lo: f32| tan * (hi.z - caster_lo).max(0.0);
    let mut caster_lo = lo.z;
    for _ in 0..2 {
        let m = reach(caster_lo);
        for o in scene.objects.iter().filter(|o| o.role.casts()) {
            let b = o.world_bounds().transform(&probe);
            let (blo, bhi) = (b.min, b.max);
            let overlaps =
                blo.x <= hi.x + m && bhi.x >= lo.x - m && blo.y <= hi.y + m && bhi.y >= lo.y - m;
            // Depth is -z: the box's nearest depth is -max.z.
            if overlaps && -bhi.z < hi.z {
                caster_lo = caster_lo.min(-bhi.z);
            }
        }
    }
    let m = reach(caster_lo);
    let centre = (lo + hi) * 0.5;
    let half_width = ((hi.x - lo.x).max(hi.y - lo.y) * 0.5 + m).max(radius * 1e-3) * 1.01;
    let span = (hi.z - caster_lo).max(0.0);
    let pad = (0.5 * span).max(radius * 1e-3);
    let eye_depth = caster_lo - pad;
    let eye = probe
        .inverse()
        .transform_point3(Vec3::new(centre.x, centre.y, -eye_depth));
    let near = pad * 0.99;
    let far = (pad + span) * 1.01;
    let mut view = LightView::sun(light, eye, half_width, near, far);
    view.depth_span = span.clamp(0.0, far - near);
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

/// Largest light radius, in bounding radii of the scene (docs/CLI.md "Numeric range").
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

/// Pixels [x0, x1) x [y0, y1) of a camera image (row 0 at the top), or texels of a light
/// buffer; empty when x0 >= x1 or y0 >= y1.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PixelBox {
    pub x0: u32,
    pub y0: u32,
    pub x1: u32,
    pub y1: u32,
}

impl PixelBox {
    pub const EMPTY: Self = Self {
        x0: u32::MAX,
        y0: u32::MAX,
        x1: 0,
        y1: 0,
    };

    /// The texels of a side-`res` buffer whose centres can fall inside the light-uv box
    /// `lo..hi` (uv 0..1 spans the buffer), one texel wider on each side for rounding,
    /// clipped to the buffer. An infinite box gives the whole buffer.
    pub fn of_uv(res: u32, lo: glam::Vec2, hi: glam::Vec2) -> Self {
        let n = res as f32;
        // f32 -> u32 `as` saturates: below 0 (and -inf) gives 0; the min keeps +inf in.
        let texel = |u: f32| (u as u32).min(res);
        Self {
            x0: texel((lo.x * n).floor() - 1.0),
            y0: texel((lo.y * n).floor() - 1.0),
            x1: texel((hi.x * n).ceil() + 1.0),
            y1: texel((hi.y * n).ceil() + 1.0),
        }
    }

    pub fn whole(width: u32, height: u32) -> Self {
        Self {
            x0: 0,
            y0: 0,
            x1: width,
            y1: height,
        }
    }

    pub fn is_empty(self) -> bool {
        self.x0 >= self.x1 || self.y0 >= self.y1
    }

    pub fn area(self) -> u64 {
        if self.is_empty() {
            0
        } else {
            (self.x1 - self.x0) as u64 * (self.y1 - self.y0) as u64
        }
    }

    /// The smallest box holding both; an empty box adds nothing.
    pub fn union(self, o: Self) -> Self {
        match (self.is_empty(), o.is_empty()) {
            (true, _) => o,
            (_, true) => self,
            _ => Self {
                x0: self.x0.min(o.x0),
                y0: self.y0.min(o.y0),
                x1: self.x1.max(o.x1),
                y1: self.y1.max(o.y1),
            },
        }
    }

    /// `n` texels wider on each side, clipped to a side-`res` buffer; empty stays empty.
    pub fn grown(self, n: u32, res: u32) -> Self {
        if self.is_empty() {
            return self;
        }
        Self {
            x0: self.x0.saturating_sub(n),
            y0: self.y0.saturating_sub(n),
            x1: self.x1.saturating_add(n).min(res),
            y1: self.y1.saturating_add(n).min(res),
        }
    }

    pub fn intersection(self, o: Self) -> Self {
        Self {
            x0: self.x0.max(o.x0),
            y0: self.y0.max(o.y0),
            x1: self.x1.min(o.x1),
            y1: self.y1.min(o.y1),
        }
    }

    pub fn intersects(self, o: Self) -> bool {
        self.x0 < o.x1 && o.x0 < self.x1 && self.y0 < o.y1 && o.y0 < self.y1
    }

    /// What of `whole` lies outside `self` (inside `whole`), as at most four boxes: the
    /// rows above and below, then the columns left and right of it.
    pub fn around(self, whole: Self) -> Vec<Self> {
        let (y0, y1) = (
            self.y0.clamp(whole.y0, whole.y1),
            self.y1.clamp(whole.y0, whole.y1),
        );
        let (x0, x1) = (
            self.x0.clamp(whole.x0, whole.x1),
            self.x1.clamp(whole.x0, whole.x1),
        );
        if self.is_empty() || x0 >= x1 || y0 >= y1 {
            return vec![whole];
        }
        [
            Self { y1: y0, ..whole },
            Self { y0: y1, ..whole },
            Self {
                x0: whole.x0,
                x1: x0,
                y0,
                y1,
            },
            Self {
                x0: x1,
                x1: whole.x1,
                y0,
                y1,
            },
        ]
        .into_iter()
        .filter(|b| !b.is_empty())
        .collect()
    }
}

/// A convex polytope as its faces' polygons: what `screen_box` projects after `clip`
/// has cut it down (an object's box to the part a light-space box can shadow, and to
/// what lies in front of the camera's near plane).
#[derive(Clone, Debug)]
pub struct Polytope {
    faces: Vec<Vec<Vec3>>,
}

impl Polytope {
    /// The hexahedron with these corners, corner i's bits 0, 1 and 2 choosing its x, y and
    /// z side (`Aabb::corners`' order; a box through any affine map).
    pub fn hexahedron(c: &[Vec3; 8]) -> Self {
        let quad = |i: [usize; 4]| i.iter().map(|&k| c[k]).collect();
        Self {
            faces: vec![
                quad([0, 2, 6, 4]),
                quad([1, 3, 7, 5]),
                quad([0, 1, 5, 4]),
                quad([2, 3, 7, 6]),
                quad([0, 1, 3, 2]),
                quad([4, 5, 7, 6]),
            ],
        }
    }

    pub fn is_empty(&self) -> bool {
        self.faces.is_empty()
    }

    /// Its faces' corners (each vertex once per face it is on).
    pub fn vertices(&self) -> impl Iterator<Item = &Vec3> {
        self.faces.iter().flatten()
    }

    /// Keeps the part where `plane` · (x, 1) >= 0: each face clipped (Sutherland-Hodgman),
    /// and the cut closed by a face on the plane, so that later cuts see a closed solid.
    pub fn clip(&mut self, plane: Vec4) {
        let side = |p: Vec3| plane.dot(p.extend(1.0));
        let mut cut = Vec::new();
        let mut faces = Vec::with_capacity(self.faces.len() + 1);
        for face in &self.faces {
            let mut kept = Vec::with_capacity(face.len() + 2);
            for (i, &a) in face.iter().enumerate() {
                let b = face[(i + 1) % face.len()];
                let (sa, sb) = (side(a), side(b));
                if sa >= 0.0 {
                    kept.push(a);
                }
                if (sa >= 0.0) != (sb >= 0.0) {
                    let x = a.lerp(b, sa / (sa - sb));
                    kept.push(x);
                    cut.push(x);
                }
            }
            if kept.len() >= 3 {
                faces.push(kept);
            }
        }
        if cut.len() >= 3 {
            // The crossings in order around their centroid, in a basis of the plane.
            let n = plane.truncate().normalize_or_zero();
            let centre = cut.iter().sum::<Vec3>() / cut.len() as f32;
            let u = n.any_orthonormal_vector();
            let v = n.cross(u);
            let angle = |p: &Vec3| (p - centre).dot(v).atan2((p - centre).dot(u));
            cut.sort_by(|a, b| angle(a).total_cmp(&angle(b)));
            faces.push(cut);
        }
        self.faces = faces;
    }

    /// The pixels of a `width` x `height` image drawn through `view_proj`
    /// (`camera_view_proj`: Vulkan clip space, z in \[0, w\], y down) that can see a
    /// point of the polytope: the screen bounds of its part in front of the near plane,
    /// one pixel wider each side for rounding, clipped to the image. `None` when nothing
    /// of it is in front of the near plane or in the image.
    pub fn screen_box(&self, view_proj: Mat4, width: u32, height: u32) -> Option<PixelBox> {
        let mut front = self.clone();
        // Clip z >= 0: the near plane, as a world-space plane (the matrix's third row).
        front.clip(view_proj.row(2));
        let size = glam::Vec2::new(width as f32, height as f32);
        let (mut lo, mut hi) = (glam::Vec2::INFINITY, glam::Vec2::NEG_INFINITY);
        for p in front.faces.iter().flatten() {
            let c = view_proj * p.extend(1.0);
            if c.w <= 0.0 {
                // Not a perspective camera's clip point: assume every pixel.
                return Some(PixelBox::whole(width, height));
            }
            let px = (c.truncate().truncate() / c.w * 0.5 + 0.5) * size;
            (lo, hi) = (lo.min(px), hi.max(px));
        }
        if front.is_empty() {
            return None;
        }
        if !(lo.is_finite() && hi.is_finite()) {
            return Some(PixelBox::whole(width, height));
        }
        // f32 -> u32 `as` saturates below 0; the min keeps the box inside the image.
        let pixel = |v: f32, n: u32| (v as u32).min(n);
        let b = PixelBox {
            x0: pixel(lo.x.floor() - 1.0, width),
            y0: pixel(lo.y.floor() - 1.0, height),
            x1: pixel(hi.x.ceil() + 1.0, width),
            y1: pixel(hi.y.ceil() + 1.0, height),
        };
        (!b.is_empty()).then_some(b)
    }
}

/// How one object's pixels divide between a final pass's two shaders
/// (`gpu::passes::FinalPass::split`): boxes that tile the object's screen box (`Polytope::
/// screen_box` of its world `corners`), each `true` where a point of the object inside one
/// of `regions` (each the intersection of its half-spaces plane · (x, 1) >= 0: where
/// visibility can be below 1) may be seen, `false` where none can. Cut into up to `bands`
/// rows, each with its own shadowed columns, which follow a slanted shadow closer than one
/// box; `bands` 0 keeps the whole screen box shadowed when any of it is (a heavy mesh, whose
/// vertices each part would shade again). Empty when the object is not on screen.
pub fn split_object(
    corners: &[Vec3; 8],
    regions: &[Vec<Vec4>],
    view_proj: Mat4,
    width: u32,
    height: u32,
    bands: u32,
) -> Vec<(bool, PixelBox)> {
    let full = Polytope::hexahedron(corners);
    let Some(screen) = full.screen_box(view_proj, width, height) else {
        return Vec::new();
    };
    let side = |p: &Vec4, c: &Vec3| p.dot(c.extend(1.0));
    // The regions the box may reach: none of their planes has every corner outside.
    let reached: Vec<&Vec<Vec4>> = regions
        .iter()
        .filter(|r| !r.iter().any(|p| corners.iter().all(|c| side(p, c) < 0.0)))
        .collect();
    if reached.is_empty() {
        return vec![(false, screen)];
    }
    let inside = |r: &&Vec<Vec4>| corners.iter().all(|c| r.iter().all(|p| side(p, c) >= 0.0));
    if bands == 0 || reached.iter().any(inside) {
        return vec![(true, screen)];
    }
    let cuts: Vec<Polytope> = reached
        .iter()
        .map(|r| {
            let mut cut = full.clone();
            for &p in r.iter() {
                cut.clip(p);
            }
            cut
        })
        .filter(|c| !c.is_empty())
        .collect();
    // The union of the cuts' screen boxes inside `within` (rows of it), if any.
    let seen = |cuts: &[Polytope], within: PixelBox| {
        cuts.iter()
            .filter_map(|c| c.screen_box(view_proj, width, height))
            .map(|b| b.intersection(within))
            .filter(|b| !b.is_empty())
            .reduce(PixelBox::union)
    };
    let Some(sb) = seen(&cuts, screen) else {
        return vec![(false, screen)];
    };
    let mut parts = vec![
        (
            false,
            PixelBox {
                y1: sb.y0,
                ..screen
            },
        ),
        (
            false,
            PixelBox {
                y0: sb.y1,
                ..screen
            },
        ),
    ];
    // Pixel row y <-> clip y / w = 2 y / height - 1 (y down in `camera_view_proj`).
    let ndc = |y: f32| 2.0 * y / height as f32 - 1.0;
    let (ry, rw) = (view_proj.row(1), view_proj.row(3));
    let rows = sb.y1 - sb.y0;
    let n = bands.min(rows);
    for k in 0..n {
        let band = PixelBox {
            y0: sb.y0 + rows * k / n,
            y1: sb.y0 + rows * (k + 1) / n,
            ..screen
        };
        let in_band: Vec<Polytope> = cuts
            .iter()
            .map(|c| {
                let mut b = c.clone();
                // A pixel wider each way: points of the band's edge rows stay in.
                b.clip(ry - rw * ndc(band.y0 as f32 - 1.0));
                b.clip(rw * ndc(band.y1 as f32 + 1.0) - ry);
                b
            })
            .collect();
        match seen(&in_band, band) {
            // Whole rows: the band's columns only.
            Some(b) => {
                let mid = PixelBox {
                    y0: band.y0,
                    y1: band.y1,
                    ..b
                };
                parts.push((true, mid));
                parts.extend(mid.around(band).into_iter().map(|b| (false, b)));
            }
            None => parts.push((false, band)),
        }
    }
    parts.retain(|(_, b)| !b.is_empty());
    parts
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

    fn unit_cube() -> [Vec3; 8] {
        Aabb::new(Vec3::ZERO, Vec3::ONE).corners()
    }

    /// Clipping keeps exactly the part on the plane's positive side, and closes each cut,
    /// so that a second and third cut still find every corner of the solid.
    #[test]
    fn clipped_polytopes_keep_the_part_inside_every_plane() {
        let mut p = Polytope::hexahedron(&unit_cube());
        // x <= 0.5, then x + y <= 1 (through the first cut's face), then z <= 0.25.
        let planes = [
            Vec4::new(-1.0, 0.0, 0.0, 0.5),
            Vec4::new(-1.0, -1.0, 0.0, 1.0),
            Vec4::new(0.0, 0.0, -1.0, 0.25),
        ];
        for q in planes {
            p.clip(q);
        }
        let (mut lo, mut hi) = (Vec3::INFINITY, Vec3::NEG_INFINITY);
        for v in p.vertices() {
            for q in planes {
                assert!(q.dot(v.extend(1.0)) >= -1e-6, "{v} outside {q}");
            }
            (lo, hi) = (lo.min(*v), hi.max(*v));
        }
        assert!(lo.abs_diff_eq(Vec3::ZERO, 1e-6), "{lo}");
        assert!(hi.abs_diff_eq(Vec3::new(0.5, 1.0, 0.25), 1e-6), "{hi}");
        // (0.5, 0.5, z) is a corner made by two cuts: only the closed cut faces hold it.
        assert!(
            p.vertices()
                .any(|v| v.abs_diff_eq(Vec3::new(0.5, 0.5, 0.25), 1e-6)),
            "the corner of the first two cuts is missing"
        );
        p.clip(Vec4::new(0.0, 0.0, 1.0, -2.0));
        assert!(p.is_empty());
    }

    /// A thin ground box, a camera above it and a slanted slab of "shadow" across it (the
    /// shape the final pass splits): the parts tile the ground's screen box without
    /// overlap, every point of the ground inside the slab lands in a shadowed part, and the
    /// bands follow the slant with less area than one box.
    #[test]
    fn split_parts_tile_the_screen_box_and_hold_every_shadowed_point() {
        let (w, h) = (320, 240);
        let view = Mat4::look_at_rh(Vec3::new(0.0, 4.0, 6.0), Vec3::ZERO, Vec3::Y);
        let mut proj = Mat4::perspective_rh(50f32.to_radians(), w as f32 / h as f32, 0.1, 50.0);
        proj.y_axis.y = -proj.y_axis.y;
        let view_proj = proj * view;
        let ground = Aabb::new(Vec3::new(-5.0, -0.01, -5.0), Vec3::new(5.0, 0.0, 5.0)).corners();
        // A diagonal strip 1 wide: |x - z| <= 0.5, and x >= -2.
        let planes = [
            Vec4::new(-1.0, 0.0, 1.0, 0.5),
            Vec4::new(1.0, 0.0, -1.0, 0.5),
            Vec4::new(1.0, 0.0, 0.0, 2.0),
        ];
        let screen = Polytope::hexahedron(&ground)
            .screen_box(view_proj, w, h)
            .unwrap();
        let mut shadowed_area = Vec::new();
        for bands in [1, 8] {
            let parts = split_object(&ground, &[planes.to_vec()], view_proj, w, h, bands);
            let total: u64 = parts.iter().map(|(_, b)| b.area()).sum();
            assert_eq!(total, screen.area(), "{bands} bands: {parts:?}");
            for (i, (_, a)) in parts.iter().enumerate() {
                assert!(a.intersection(screen) == *a, "{a:?} outside {screen:?}");
                for (_, b) in &parts[i + 1..] {
                    assert!(!a.intersects(*b), "{a:?} and {b:?} overlap");
                }
            }
            // Points of the ground inside the strip, on a fine grid.
            let mut checked = 0;
            for i in 0..=400 {
                for j in 0..=400 {
                    let p = Vec3::new(-5.0 + i as f32 / 40.0, 0.0, -5.0 + j as f32 / 40.0);
                    if planes.iter().any(|q| q.dot(p.extend(1.0)) < 0.0) {
                        continue;
                    }
                    let c = view_proj * p.extend(1.0);
                    let px = (c.truncate().truncate() / c.w * 0.5 + 0.5)
                        * glam::Vec2::new(w as f32, h as f32);
                    if px.x < 0.0 || px.y < 0.0 || px.x >= w as f32 || px.y >= h as f32 {
                        continue;
                    }
                    let (x, y) = (px.x as u32, px.y as u32);
                    let inside = |b: &PixelBox| x >= b.x0 && x < b.x1 && y >= b.y0 && y < b.y1;
                    assert!(
                        parts.iter().any(|(s, b)| *s && inside(b)),
                        "{bands} bands: shadowed point {p} at pixel ({x}, {y}) in no shadowed part"
                    );
                    checked += 1;
                }
            }
            assert!(checked > 1000, "{checked}");
            shadowed_area.push(
                parts
                    .iter()
                    .filter(|(s, _)| *s)
                    .map(|(_, b)| b.area())
                    .sum::<u64>(),
            );
        }
        assert!(
            (shadowed_area[1] as f64) < 0.7 * shadowed_area[0] as f64,
            "bands do not follow the slant: {shadowed_area:?}"
        );
        assert!((shadowed_area[0] as f64) < 0.9 * screen.area() as f64);
        // Outside one plane entirely: one unshadowed part; no bands: one shadowed part.
        let away = [Vec4::new(1.0, 0.0, 0.0, -9.0)];
        assert_eq!(
            split_object(&ground, &[away.to_vec()], view_proj, w, h, 8),
            vec![(false, screen)]
        );
        assert_eq!(
            split_object(&ground, &[planes.to_vec()], view_proj, w, h, 0),
            vec![(true, screen)]
        );
    }

    /// Two regions (two casters' shadows): a point inside either lands in a shadowed
    /// part, and the parts still tile the screen box.
    #[test]
    fn split_parts_hold_the_points_of_every_region() {
        let (w, h) = (240, 160);
        let view = Mat4::look_at_rh(Vec3::new(0.0, 5.0, 5.0), Vec3::ZERO, Vec3::Y);
        let mut proj = Mat4::perspective_rh(60f32.to_radians(), 1.5, 0.1, 50.0);
        proj.y_axis.y = -proj.y_axis.y;
        let vp = proj * view;
        let ground = Aabb::new(Vec3::new(-4.0, -0.01, -4.0), Vec3::new(4.0, 0.0, 4.0)).corners();
        // x in [-3, -2] and z in [1, 2]; x + z in [2, 3].
        let regions = vec![
            vec![
                Vec4::new(1.0, 0.0, 0.0, 3.0),
                Vec4::new(-1.0, 0.0, 0.0, -2.0),
            ],
            vec![
                Vec4::new(1.0, 0.0, 1.0, -2.0),
                Vec4::new(-1.0, 0.0, -1.0, 3.0),
            ],
            vec![
                Vec4::new(0.0, 0.0, 1.0, -1.0),
                Vec4::new(0.0, 0.0, -1.0, 2.0),
            ],
        ];
        let screen = Polytope::hexahedron(&ground).screen_box(vp, w, h).unwrap();
        let parts = split_object(&ground, &regions, vp, w, h, 8);
        assert_eq!(
            parts.iter().map(|(_, b)| b.area()).sum::<u64>(),
            screen.area()
        );
        let mut checked = 0;
        for i in 0..=320 {
            for j in 0..=320 {
                let p = Vec3::new(-4.0 + i as f32 / 40.0, 0.0, -4.0 + j as f32 / 40.0);
                let within = |r: &Vec<Vec4>| r.iter().all(|q| q.dot(p.extend(1.0)) >= 0.0);
                if !regions.iter().any(within) {
                    continue;
                }
                let c = vp * p.extend(1.0);
                let px = (c.truncate().truncate() / c.w * 0.5 + 0.5)
                    * glam::Vec2::new(w as f32, h as f32);
                let (x, y) = (px.x as u32, px.y as u32);
                if px.x < 0.0 || px.y < 0.0 || x >= w || y >= h {
                    continue;
                }
                let inside = |b: &PixelBox| x >= b.x0 && x < b.x1 && y >= b.y0 && y < b.y1;
                assert!(
                    parts.iter().any(|(s, b)| *s && inside(b)),
                    "{p} at ({x}, {y})"
                );
                checked += 1;
            }
        }
        assert!(checked > 1000, "{checked}");
        let shadowed: u64 = parts
            .iter()
            .filter(|(s, _)| *s)
            .map(|(_, b)| b.area())
            .sum();
        assert!(
            (shadowed as f64) < 0.8 * screen.area() as f64,
            "{shadowed} of {}",
            screen.area()
        );
    }

    /// A box reaching behind the camera is cut at the near plane, not dropped or
    /// projected through the eye; one wholly behind is off screen.
    #[test]
    fn screen_boxes_cut_at_the_near_plane() {
        let (w, h) = (200, 100);
        let view = Mat4::look_at_rh(Vec3::new(0.0, 1.0, 0.0), Vec3::new(0.0, 1.0, -1.0), Vec3::Y);
        let mut proj = Mat4::perspective_rh(60f32.to_radians(), 2.0, 0.1, 100.0);
        proj.y_axis.y = -proj.y_axis.y;
        let vp = proj * view;
        // The ground from behind the camera to far ahead: the lower half of the image.
        let ground = Aabb::new(Vec3::new(-50.0, -0.01, -50.0), Vec3::new(50.0, 0.0, 50.0));
        let b = Polytope::hexahedron(&ground.corners())
            .screen_box(vp, w, h)
            .unwrap();
        assert_eq!((b.x0, b.x1, b.y1), (0, w, h), "{b:?}");
        assert!((48..=52).contains(&b.y0), "{b:?}");
        let behind = Aabb::new(Vec3::new(-1.0, 0.0, 1.0), Vec3::new(1.0, 2.0, 3.0));
        assert_eq!(
            Polytope::hexahedron(&behind.corners()).screen_box(vp, w, h),
            None
        );
    }
}
