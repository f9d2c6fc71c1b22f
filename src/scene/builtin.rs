//! Built-in scenes by name, the framing of a bare OBJ on a ground plane, and the helpers
//! that aim a spotlight and a camera at a set of casters (shared with scene files).
//!
//! World conventions: Y is up, the ground plane is y = 0, units are "metres" with the
//! casters a few units tall. Every scene is deterministic: same name, same triangles.

use super::{obj, primitives as prim, Aabb, Camera, Light, Mesh, Object, Role, Scene};
use anyhow::{bail, Result};
use glam::{Mat4, Quat, Vec2, Vec3};
use std::path::Path;
use std::sync::Arc;

/// Built-in scene names, in the order the CLI and the bench list them.
pub const BUILTIN_SCENES: &[&str] = &[
    "cylinder",
    "boxes",
    "overlap",
    "fence",
    "bunny",
    "primitives",
    "dense",
    "dense-1m",
    "sun-courtyard",
    "sun-bunny",
];

/// The built-in scenes lit by a sun (a subset of `BUILTIN_SCENES`; a unit test keeps the two
/// in step): the goldens, the stress suite and the bench's sun tables loop over these.
pub const SUN_SCENES: &[&str] = &["sun-courtyard", "sun-bunny"];

/// The Stanford bunny, compiled in so the binary works from any directory.
const BUNNY_OBJ: &str = include_str!(concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/assets/scenes/bunny.obj"
));

const GROUND: Vec3 = Vec3::new(0.8, 0.8, 0.78);

/// The built-in scene `name`, or `None` when no built-in has that name.
pub fn builtin(name: &str) -> Result<Option<Scene>> {
    let s = match name {
        "cylinder" => cylinder(),
        "boxes" => boxes(),
        "overlap" => overlap(),
        "fence" => fence(),
        "bunny" => bunny()?,
        "primitives" => primitives(),
        "dense" => dense(),
        "dense-1m" => dense_1m(),
        "sun-courtyard" => sun_courtyard()?,
        "sun-bunny" => sun_bunny()?,
        _ => return Ok(None),
    };
    Ok(Some(s))
}

/// Collects objects, then aims the light and the camera at what was added.
struct Builder {
    name: String,
    objects: Vec<Object>,
}

impl Builder {
    fn new(name: &str) -> Self {
        Self {
            name: name.into(),
            objects: Vec::new(),
        }
    }

    fn add(&mut self, name: &str, mesh: Arc<Mesh>, transform: Mat4, role: Role, albedo: Vec3) {
        self.objects
            .push(Object::new(name, mesh, transform, role, albedo));
    }

    fn ground(&mut self, size: f32, segments: u32) {
        let m = Arc::new(prim::plane(Vec2::splat(size), segments));
        self.add("ground", m, Mat4::IDENTITY, Role::Receiver, GROUND);
    }

    /// Finishes with a spotlight at `light_pos` fitted to the casters and their shadow
    /// on y = 0, a light radius of `radius_frac` of that region's diagonal, and a camera
    /// looking at the region from direction `cam_dir`.
    fn finish(self, light_pos: Vec3, radius_frac: f32, cam_dir: Vec3) -> Scene {
        let (light, camera) = rig(&self.objects, light_pos, 0.0, radius_frac, cam_dir);
        Scene {
            name: self.name,
            objects: self.objects,
            light,
            camera,
        }
    }
}

/// A spotlight at `light_pos` and a camera for `objects`: the light looks at the centre of
/// the casters plus their shadow footprint on y = `ground_y`, its fov covers both with a
/// margin, and its radius is `radius_frac` of that region's diagonal. The camera frames the
/// same region from direction `cam_dir` with a 45 degree fov.
pub(crate) fn rig(
    objects: &[Object],
    light_pos: Vec3,
    ground_y: f32,
    radius_frac: f32,
    cam_dir: Vec3,
) -> (Light, Camera) {
    let casters = objects
        .iter()
        .filter(|o| o.role.casts())
        .fold(Aabb::EMPTY, |b, o| b.union(o.world_bounds()));
    let casters = if casters.is_empty() {
        objects
            .iter()
            .fold(Aabb::EMPTY, |b, o| b.union(o.world_bounds()))
    } else {
        casters
    };
    let region = shadow_region(light_pos, &casters, ground_y);
    let light = fit_light(light_pos, &region, region.extent().length() * radius_frac);
    let camera = fit_camera(&region, cam_dir, 45.0);
    (light, camera)
}

/// The casters' box together with where its corners' shadows land on y = `ground_y`.
/// Corners at or above the light cast no footprint; grazing ones are capped so a
/// nearly horizontal light does not stretch the region to infinity.
pub(crate) fn shadow_region(light_pos: Vec3, casters: &Aabb, ground_y: f32) -> Aabb {
    let mut region = *casters;
    if casters.is_empty() {
        return region;
    }
    for c in casters.corners() {
        let drop = light_pos.y - c.y;
        if drop > 1e-4 && light_pos.y > ground_y {
            let t = ((light_pos.y - ground_y) / drop).min(8.0);
            region = region.including(light_pos + (c - light_pos) * t);
        }
    }
    region
}

/// A spotlight at `position` aimed at the centre of `region` with the narrowest fov that
/// holds all of it (plus a margin so shadow edges do not touch the map border).
pub(crate) fn fit_light(position: Vec3, region: &Aabb, radius: f32) -> Light {
    let target = region.center();
    let axis = (target - position).normalize_or(Vec3::NEG_Y);
    let half = region
        .corners()
        .iter()
        .map(|&c| axis.angle_between((c - position).normalize_or(axis)))
        .fold(0.0f32, f32::max);
    let fov_deg = (half.to_degrees() * 2.0 * 1.1 + 2.0).clamp(10.0, 150.0);
    Light {
        position,
        target,
        fov_deg,
        radius,
        kind: super::LightKind::Spot,
    }
}

/// A camera looking at `region`'s centre from direction `dir`, far enough that the
/// region's bounding sphere fits the (vertical) fov.
pub(crate) fn fit_camera(region: &Aabb, dir: Vec3, fov_deg: f32) -> Camera {
    let target = region.center();
    let r = region.radius().max(1e-3);
    let dist = r / (fov_deg.to_radians() * 0.5).sin();
    Camera {
        position: target + dir.normalize_or(Vec3::new(0.0, 0.6, 0.8)) * dist,
        target,
        up: Vec3::Y,
        fov_deg,
    }
}

fn at(t: Vec3) -> Mat4 {
    Mat4::from_translation(t)
}

/// Smoothie paper Fig. 1/7: a closed cylinder on a plane, lit from the side and above so
/// its shadow falls long: a narrow penumbra at the contact, a wide one at the far end.
fn cylinder() -> Scene {
    let mut b = Builder::new("cylinder");
    b.ground(16.0, 8);
    let cyl = Arc::new(prim::cylinder(0.5, 2.0, 64));
    b.add(
        "cylinder",
        cyl,
        at(Vec3::new(0.0, 1.0, 0.0)),
        Role::Both,
        Vec3::new(0.75, 0.35, 0.25),
    );
    b.finish(Vec3::new(-6.0, 5.0, 1.0), 0.05, Vec3::new(0.35, 0.6, 1.0))
}

/// Smoothie paper Fig. 9: two boxes above a plane; the upper one shadows the lower one
/// and, past its edge, the plane.
fn boxes() -> Scene {
    let mut b = Builder::new("boxes");
    b.ground(12.0, 8);
    let lower = Arc::new(prim::cuboid(Vec3::new(2.0, 0.4, 2.0)));
    let upper = Arc::new(prim::cuboid(Vec3::new(1.0, 0.4, 1.0)));
    b.add(
        "box2",
        lower,
        at(Vec3::new(0.0, 1.0, 0.0)),
        Role::Both,
        Vec3::new(0.3, 0.5, 0.8),
    );
    b.add(
        "box1",
        upper,
        at(Vec3::new(0.6, 2.5, 0.3)),
        Role::Both,
        Vec3::new(0.8, 0.6, 0.3),
    );
    b.finish(Vec3::new(-2.0, 8.0, 1.0), 0.04, Vec3::new(0.5, 0.7, 1.0))
}

/// Smoothie paper Fig. 10: two thin blockers at different heights, side by side, so the
/// narrow penumbra of the low one overlaps the wide penumbra of the high one on the plane.
fn overlap() -> Scene {
    let mut b = Builder::new("overlap");
    b.ground(12.0, 8);
    let plate = Arc::new(prim::cuboid(Vec3::new(1.5, 0.1, 1.5)));
    b.add(
        "low",
        plate.clone(),
        at(Vec3::new(-0.6, 1.0, 0.0)),
        Role::Both,
        Vec3::new(0.3, 0.7, 0.4),
    );
    b.add(
        "high",
        plate,
        at(Vec3::new(0.9, 3.0, 0.2)),
        Role::Both,
        Vec3::new(0.7, 0.3, 0.6),
    );
    b.finish(Vec3::new(0.0, 8.0, 0.5), 0.05, Vec3::new(0.2, 0.9, 1.0))
}

/// A fence of posts and rails (rectangular holes) standing on a plane; the light is behind
/// it so the hole pattern lands on the ground in front, towards the camera.
fn fence() -> Scene {
    let mut b = Builder::new("fence");
    b.ground(14.0, 8);
    let mut fence = Mesh::default();
    let post = prim::cuboid(Vec3::new(0.12, 1.4, 0.12));
    for i in -3..=3 {
        fence.append(&post, at(Vec3::new(i as f32, 0.7, 0.0)));
    }
    let rail = prim::cuboid(Vec3::new(6.24, 0.1, 0.06));
    for y in [0.35, 0.8, 1.25] {
        fence.append(&rail, at(Vec3::new(0.0, y, 0.08)));
    }
    b.add(
        "fence",
        Arc::new(fence),
        Mat4::IDENTITY,
        Role::Both,
        Vec3::new(0.6, 0.45, 0.3),
    );
    b.finish(Vec3::new(1.5, 6.0, -4.0), 0.03, Vec3::new(0.3, 0.7, 1.0))
}

/// The Stanford bunny (3674 triangles), 2 units tall, sitting on a plane.
fn bunny() -> Result<Scene> {
    Ok(framed("bunny", vec![bunny_object()?]))
}

/// The bunny as one object, 2 units tall, standing on y = 0 centred on the Y axis.
fn bunny_object() -> Result<Object> {
    let mesh = obj::parse_obj(BUNNY_OBJ, "bunny.obj")?;
    let b = mesh.bounds();
    let s = 2.0 / b.extent().y.max(1e-6);
    let c = b.center();
    let transform = Mat4::from_scale_rotation_translation(
        Vec3::splat(s),
        Quat::IDENTITY,
        Vec3::new(-c.x * s, -b.min.y * s, -c.z * s),
    );
    let bunny = Object::new(
        "bunny",
        Arc::new(mesh),
        transform,
        Role::Both,
        Vec3::new(0.85, 0.8, 0.7),
    );
    Ok(bunny)
}

/// The example scene file `assets/scenes/sun-courtyard.toml`, compiled in: the built-in is
/// that file, so the example a user copies and the scene the goldens and the bench measure
/// cannot drift apart.
const SUN_COURTYARD_TOML: &str = include_str!(concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/assets/scenes/sun-courtyard.toml"
));

/// A courtyard of walls, a column, a ball and a ring under a sun 17 degrees above the
/// horizon: long shadows whose penumbrae widen far from contact (the wall's shadow reaches
/// several metres across the ground).
fn sun_courtyard() -> Result<Scene> {
    super::file::parse_toml(
        SUN_COURTYARD_TOML,
        "sun-courtyard",
        "sun-courtyard",
        Path::new(""),
    )
}

/// Elevation of `sun-bunny`'s sun: a high (late-morning) sun, so shadows are short and the
/// penumbra is set by the bunny's own height, the opposite of the courtyard's low sun.
const SUN_BUNNY_ELEVATION_DEG: f32 = 65.0;
/// `sun-bunny`'s angular radius: 2 degrees, twice the scene-file default, so the shadow of
/// the ears (2 units up) has a penumbra 2 x 2 tan 2deg = 0.14 units wide, several texels of
/// a 1024^2 map over the framed ground; at 1 degree the short shadows of a high sun are
/// nearly hard and every technique looks alike.
const SUN_BUNNY_ANGLE_DEG: f32 = 2.0;

/// The bunny on a ground plane under a high sun: a tall caster whose shadow starts at its
/// feet (contact hardening) and softens towards the ears.
fn sun_bunny() -> Result<Scene> {
    let mut s = framed("sun-bunny", vec![bunny_object()?]);
    let casters = s.caster_bounds().unwrap_or(Aabb::EMPTY);
    let size = casters.extent().max_element().max(1e-3);
    let e = SUN_BUNNY_ELEVATION_DEG.to_radians();
    // From the camera's side and to the left, so the shadow falls back and to the right.
    let azimuth = (-40.0f32).to_radians();
    let dir = Vec3::new(azimuth.sin() * e.cos(), e.sin(), azimuth.cos() * e.cos());
    s.light = Light::sun(dir, casters.center(), SUN_BUNNY_ANGLE_DEG, 4.0 * size);
    Ok(s)
}

/// Several primitives, about 10k triangles: the size of the smoothie paper's timings.
fn primitives() -> Scene {
    let mut b = Builder::new("primitives");
    b.ground(14.0, 16);
    let sphere = Arc::new(prim::sphere(0.6, 32, 16));
    let torus = Arc::new(prim::torus(0.6, 0.2, 48, 16));
    let cyl = Arc::new(prim::cylinder(0.3, 1.2, 48));
    let cube = Arc::new(prim::cuboid(Vec3::splat(0.7)));
    let red = Vec3::new(0.8, 0.3, 0.25);
    let blue = Vec3::new(0.3, 0.45, 0.8);
    let green = Vec3::new(0.35, 0.7, 0.35);
    let gold = Vec3::new(0.85, 0.7, 0.3);
    for (i, p) in [
        (-2.0, 0.6, -2.0),
        (2.0, 1.5, -1.5),
        (-1.0, 2.2, 1.5),
        (1.5, 0.6, 2.0),
    ]
    .into_iter()
    .enumerate()
    {
        b.add(
            &format!("sphere{i}"),
            sphere.clone(),
            at(p.into()),
            Role::Both,
            red,
        );
    }
    // Tori stand up, tilt and float so their holes throw ring-shaped shadows.
    for (i, (p, rx, rz)) in [
        (Vec3::new(0.0, 0.8, 0.0), 90.0f32, 0.0f32),
        (Vec3::new(-2.5, 1.8, 0.5), 30.0, 20.0),
        (Vec3::new(2.5, 0.2, 0.0), 0.0, 0.0),
    ]
    .into_iter()
    .enumerate()
    {
        let r = Mat4::from_rotation_z(rz.to_radians()) * Mat4::from_rotation_x(rx.to_radians());
        b.add(
            &format!("torus{i}"),
            torus.clone(),
            at(p) * r,
            Role::Both,
            blue,
        );
    }
    for (i, p) in [
        (-3.0, 0.6, -0.5),
        (0.5, 0.6, -2.8),
        (3.0, 1.8, 2.5),
        (-0.5, 0.6, 3.0),
    ]
    .into_iter()
    .enumerate()
    {
        b.add(
            &format!("cylinder{i}"),
            cyl.clone(),
            at(p.into()),
            Role::Both,
            green,
        );
    }
    for (i, (p, yaw)) in [
        (Vec3::new(1.0, 0.35, -0.8), 20.0f32),
        (Vec3::new(-1.5, 0.35, -0.2), 45.0),
        (Vec3::new(0.5, 2.0, 1.0), 10.0),
        (Vec3::new(-2.8, 0.35, 2.6), 70.0),
    ]
    .into_iter()
    .enumerate()
    {
        b.add(
            &format!("box{i}"),
            cube.clone(),
            at(p) * Mat4::from_rotation_y(yaw.to_radians()),
            Role::Both,
            gold,
        );
    }
    b.finish(Vec3::new(-4.0, 10.0, 3.0), 0.03, Vec3::new(0.4, 0.8, 1.0))
}

/// A floating cluster of bumpy spheres ("asteroids") over a plane: `nx` x `nz` of them,
/// each `segments` x `rings`, from `variants` distinct noise seeds (shared meshes keep the
/// memory down; random rotations and sizes hide the repetition).
fn asteroids(
    name: &str,
    nx: u32,
    nz: u32,
    segments: u32,
    rings: u32,
    amp: f32,
    variants: u64,
) -> Scene {
    let mut b = Builder::new(name);
    let spacing = 1.0;
    let span = spacing * nx.max(nz) as f32;
    b.ground(span * 2.5, 16);
    let meshes: Vec<Arc<Mesh>> = (0..variants)
        .map(|s| Arc::new(prim::bumpy_sphere(0.42, segments, rings, amp, s + 1)))
        .collect();
    let mut rng = prim::Lcg(0x5EED ^ (nx as u64 * 131 + nz as u64));
    for j in 0..nz {
        for i in 0..nx {
            let x = (i as f32 - (nx as f32 - 1.0) * 0.5) * spacing + rng.range(-0.15, 0.15);
            let z = (j as f32 - (nz as f32 - 1.0) * 0.5) * spacing + rng.range(-0.15, 0.15);
            let y = 0.8 + rng.range(0.0, 1.2);
            let s = rng.range(0.75, 1.05);
            let rot = Quat::from_axis_angle(rng.unit_vec(), rng.range(0.0, std::f32::consts::TAU));
            let k = ((i + j * nx) as u64 % variants) as usize;
            let albedo = Vec3::new(
                rng.range(0.4, 0.9),
                rng.range(0.4, 0.9),
                rng.range(0.4, 0.9),
            );
            b.add(
                &format!("rock{}", i + j * nx),
                meshes[k].clone(),
                Mat4::from_scale_rotation_translation(Vec3::splat(s), rot, Vec3::new(x, y, z)),
                Role::Both,
                albedo,
            );
        }
    }
    let light = Vec3::new(-0.3, 2.2, 0.2) * span + Vec3::Y * 2.0;
    b.finish(light, 0.02, Vec3::new(0.4, 0.8, 1.0))
}

/// At least 50k triangles with about 10k silhouette edges from the light, like the
/// smoothie paper's motorbike: silhouette extraction and smoothie rasterisation dominate.
fn dense() -> Scene {
    asteroids("dense", 6, 6, 48, 24, 0.22, 6)
}

/// About a million triangles, built procedurally in well under a second.
fn dense_1m() -> Scene {
    asteroids("dense-1m", 10, 10, 100, 50, 0.12, 8)
}

/// The name of the ground plane `framed` adds.
pub(crate) const FRAMED_GROUND: &str = "ground";

/// Puts `casters` on a ground plane (at their lowest point, four times their footprint)
/// under a default light above and to the side, with a camera that sees them and their
/// shadows. Used for the bunny and for any bare OBJ.
fn framed(name: &str, casters: Vec<Object>) -> Scene {
    let bounds = casters
        .iter()
        .fold(Aabb::EMPTY, |b, o| b.union(o.world_bounds()));
    let size = bounds.extent().max_element().max(1e-3);
    let c = bounds.center();
    let ground_y = bounds.min.y;
    let plane = prim::plane(Vec2::splat(size * 4.0), 8);
    let mut objects = casters;
    objects.push(Object::new(
        FRAMED_GROUND,
        Arc::new(plane),
        at(Vec3::new(c.x, ground_y, c.z)),
        Role::Receiver,
        GROUND,
    ));
    let light_pos = Vec3::new(c.x, ground_y, c.z) + Vec3::new(-1.2, 2.5, 0.8) * size;
    let (light, camera) = rig(
        &objects,
        light_pos,
        ground_y,
        0.04,
        Vec3::new(0.4, 0.6, 1.0),
    );
    Scene {
        name: name.into(),
        objects,
        light,
        camera,
    }
}

/// A bare OBJ file as a scene: the mesh as-is (no rescale, so exported coordinates match
/// the file), role both, framed on a ground plane.
pub(crate) fn framed_obj(path: &Path) -> Result<Scene> {
    let mesh = obj::load_obj(path)?;
    let name = path
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "mesh".into());
    if mesh.triangle_count() == 0 {
        bail!("{}: no triangles", super::input::shown_path(path));
    }
    let o = Object::new(
        name.clone(),
        Arc::new(mesh),
        Mat4::IDENTITY,
        Role::Both,
        Vec3::splat(0.8),
    );
    Ok(framed(&name, vec![o]))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `SUN_SCENES` holds exactly the built-ins whose light is a sun.
    #[test]
    fn sun_scenes_are_the_builtins_lit_by_a_sun() {
        let suns: Vec<&str> = BUILTIN_SCENES
            .iter()
            .copied()
            .filter(|&n| n != "dense-1m" && builtin(n).unwrap().unwrap().light.is_sun())
            .collect();
        assert_eq!(suns, SUN_SCENES);
    }

    /// The ground is big enough for each spotlight built-in's shadow, and the light's cone
    /// holds the casters and that shadow.
    #[test]
    fn shadows_land_on_the_ground_inside_the_light_cone() {
        // Not the sun scenes: a low sun's shadows run past any finite ground (sun-courtyard's
        // wall shadow leaves its 16-unit ground), and its map is fitted to what the camera
        // sees, not to a cone.
        for &name in BUILTIN_SCENES.iter().filter(|n| !SUN_SCENES.contains(n)) {
            let s = builtin(name).unwrap().unwrap();
            let ground = s
                .objects
                .iter()
                .find(|o| o.name == "ground")
                .unwrap()
                .world_bounds();
            let casters = s.caster_bounds().unwrap();
            let region = shadow_region(s.light.position, &casters, ground.max.y);
            assert!(
                region.min.x >= ground.min.x
                    && region.min.z >= ground.min.z
                    && region.max.x <= ground.max.x
                    && region.max.z <= ground.max.z,
                "{name}: shadow region {region:?} off the ground {ground:?}"
            );
            let axis = (s.light.target - s.light.position).normalize();
            for c in region.corners() {
                let a = axis.angle_between(c - s.light.position).to_degrees();
                assert!(
                    a < s.light.fov_deg * 0.5,
                    "{name}: {c} outside the light cone"
                );
            }
        }
    }
}
