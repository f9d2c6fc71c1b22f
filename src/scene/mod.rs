//! Scenes: meshes (OBJ through tobj, built-in primitives), objects with a role, one
//! light (a spotlight with a radius, or a sun with an angular radius), one camera. Built-in scenes by name, TOML scene files, glTF
//! scenes, bare OBJ files framed on a ground plane. `export` writes the scene back out for
//! outside tools (OBJ + JSON, or glTF).

use anyhow::{bail, Result};
use glam::{Mat3, Mat4, Vec3, Vec4};
use std::path::Path;
use std::sync::Arc;

pub mod builtin;
pub mod export;
pub mod file;
mod gltf_decode;
pub mod gltf_io;
pub mod input;
pub mod obj;
pub mod primitives;

pub use builtin::BUILTIN_SCENES;
pub use export::export_obj;
pub use gltf_io::export_gltf;
pub use input::LoadOptions;

/// A triangle list. `normals` has one entry per position (computed where the source had none).
/// Positions may be split (flat shading): silhouette code welds them by value.
#[derive(Clone, Debug, Default)]
pub struct Mesh {
    pub positions: Vec<Vec3>,
    pub normals: Vec<Vec3>,
    pub indices: Vec<u32>,
}

/// What an object does for shadows. Every object is seen by the camera.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Deserialize, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Role {
    /// Casts shadows; its own pixels get visibility 1.
    Caster,
    /// Receives shadows, casts none.
    Receiver,
    /// Casts and receives.
    Both,
}

impl Role {
    pub fn casts(self) -> bool {
        matches!(self, Role::Caster | Role::Both)
    }
    pub fn receives(self) -> bool {
        matches!(self, Role::Receiver | Role::Both)
    }
}

#[derive(Clone, Debug)]
pub struct Object {
    pub name: String,
    pub mesh: Arc<Mesh>,
    /// Object to world.
    pub transform: Mat4,
    pub role: Role,
    pub albedo: Vec3,
    bounds: BoundsCache,
}

/// The last `Object::world_bounds` and the (transform bits, mesh) it was computed for.
/// Every frame fits the light's near/far and the camera's to every object's bounds (and
/// smoothies its width to the casters'), several times over; recomputing them transforms
/// every vertex of unmoved objects too (`dense-1m`: ~3M points per call). Holding the mesh's
/// `Arc` keeps its address from being reused by a replacement mesh while cached; a mesh is
/// never changed in place behind its `Arc`.
#[derive(Default)]
struct BoundsCache(std::sync::Mutex<Option<CachedBounds>>);

/// Transform bits, the mesh, its world bounds.
type CachedBounds = ([u32; 16], Arc<Mesh>, Aabb);

impl BoundsCache {
    fn get(&self, transform: &[u32; 16], mesh: &Arc<Mesh>) -> Option<Aabb> {
        let slot = self.0.lock().ok()?;
        let (t, m, b) = slot.as_ref()?;
        (t == transform && Arc::ptr_eq(m, mesh)).then_some(*b)
    }

    fn set(&self, transform: [u32; 16], mesh: &Arc<Mesh>, bounds: Aabb) {
        // A poisoned lock only means no caching.
        if let Ok(mut slot) = self.0.lock() {
            *slot = Some((transform, mesh.clone(), bounds));
        }
    }
}

impl Clone for BoundsCache {
    fn clone(&self) -> Self {
        let slot = self.0.lock().ok().and_then(|s| s.clone());
        Self(std::sync::Mutex::new(slot))
    }
}

impl std::fmt::Debug for BoundsCache {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("BoundsCache")
    }
}

/// The scene's light. A spotlight (`LightKind::Spot`) is a sphere of `radius` at `position`,
/// shadow-mapped with a perspective frustum of `fov_deg` towards `target`. A sun
/// (`LightKind::Sun`) shines from the direction `position - target` (see [`Light::sun`]);
/// its `fov_deg` and `radius` are unused.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Light {
    pub position: Vec3,
    pub target: Vec3,
    pub fov_deg: f32,
    pub radius: f32,
    pub kind: LightKind,
}

/// Which light a scene holds.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum LightKind {
    Spot,
    /// A directional light whose directions fill a disc (a cone) of `angular_radius_deg`
    /// around its axis, as the sun's do (0.27 degrees). Shadow-mapped with one orthographic
    /// map fitted to what the camera sees (`frustum::fit_light`), no cascades.
    Sun {
        angular_radius_deg: f32,
    },
}

/// The sun's angular radius when a scene gives none: 1 degree, about four times the real
/// sun's 0.27. Under the real sun a penumbra is 0.9 % of the blocker-to-receiver distance,
/// under a texel of a scene-sized shadow map for most contacts, so every technique would
/// look like `hard`; at 1 degree it is 3.5 %, soft enough to tell the techniques apart while
/// still reading as sunlight through thin haze (whose aureole widens the sun's disc).
pub const DEFAULT_SUN_ANGLE_DEG: f32 = 1.0;

/// Largest sun angular radius: beyond it the sun is a sky patch, not a sun, and the
/// orthographic map's penumbra margin (2 tan theta x the depth span) outgrows the scene.
pub const MAX_SUN_ANGLE_DEG: f32 = 20.0;

/// The (unused) cone a sun carries in `Light::fov_deg`, valid for `Scene::validate`.
const SUN_FOV_DEG: f32 = 60.0;

impl Light {
    /// A sun shining from `direction` (towards the light, any length) onto `target`, with
    /// its disc of directions `angular_radius_deg` in radius. `distance` places `position`
    /// on the axis: the point the light is drawn from in exports (a sun has no position).
    pub fn sun(direction: Vec3, target: Vec3, angular_radius_deg: f32, distance: f32) -> Light {
        Light {
            position: target + direction.normalize_or(Vec3::Y) * distance,
            target,
            fov_deg: SUN_FOV_DEG,
            radius: 0.0,
            kind: LightKind::Sun { angular_radius_deg },
        }
    }

    pub fn is_sun(&self) -> bool {
        matches!(self.kind, LightKind::Sun { .. })
    }

    /// The sun's angular radius in degrees; `None` for a spotlight.
    pub fn sun_angle_deg(&self) -> Option<f32> {
        match self.kind {
            LightKind::Sun { angular_radius_deg } => Some(angular_radius_deg),
            LightKind::Spot => None,
        }
    }

    /// Unit direction from the scene towards the light's axis (a sun's `direction`).
    pub fn direction(&self) -> Vec3 {
        (self.position - self.target).normalize_or(Vec3::Y)
    }

    /// The kind's name in scene files and exports: `spot` or `sun`.
    pub fn kind_name(&self) -> &'static str {
        if self.is_sun() {
            "sun"
        } else {
            "spot"
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    pub position: Vec3,
    pub target: Vec3,
    pub up: Vec3,
    pub fov_deg: f32,
}

#[derive(Clone, Debug)]
pub struct Scene {
    pub name: String,
    pub objects: Vec<Object>,
    pub light: Light,
    pub camera: Camera,
}

/// Axis-aligned bounds.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aabb {
    pub min: Vec3,
    pub max: Vec3,
}

/// The light's shadow-map frame: a square perspective frustum from `Light::position`,
/// towards `Light::target` with the cone's `fov_deg`, or, fitted (`LightView::fitted`), a
/// narrower square one inside the cone aimed at what matters. Light screen space is uv in \[0,1\]^2 with uv = ndc * 0.5 + 0.5
/// (no flip: rendering and sampling use the same mapping). Linear depth is the distance
/// along the light's view axis (-z in view space); along one texel's ray the ratio of two
/// linear depths equals the ratio of their distances to the light (smoothies' b/r).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LightView {
    pub position: Vec3,
    pub view: Mat4,
    pub proj: Mat4,
    pub view_proj: Mat4,
    pub near: f32,
    pub far: f32,
    /// The map's own field of view (the frustum's, not the spot's cone when fitted): every
    /// uv size and texel size derives from it.
    pub fov_deg: f32,
    /// Maps this frame's light clip coordinates to the spot cone's own (its xy / w in
    /// [-1, 1] inside the cone), so that the spot falloff follows the light's real axis and
    /// angle whatever the map is fitted to. The identity unless fitted.
    pub spot_from_clip: Mat4,
    /// Depth extent of what the light sees, before the near/far headroom (`far - near` unless
    /// fitted by `frustum::fit_light`): the scale of the depth bias.
    pub depth_span: f32,
    /// A sun's orthographic frame; `None` for a spotlight's perspective one.
    pub sun: Option<SunView>,
}

/// A sun's shadow-map frame: `proj` is orthographic (clip w = 1), the map a square of
/// `2 half_width` world units across the light's axis. Linear depth is still the distance
/// along the view axis from `LightView::position` (a point behind every caster), z in
/// \[0, 1\] maps it linearly from near to far.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SunView {
    pub half_width: f32,
    /// tan of the angular radius: a penumbra's width per unit of blocker-to-receiver distance
    /// is twice it.
    pub tan_angle: f32,
}

impl LightView {
    pub fn new(light: &Light, near: f32, far: f32) -> Self {
        let dir = (light.target - light.position).normalize_or(Vec3::NEG_Z);
        // Any up that is not parallel to the view direction.
        let up = if dir.y.abs() > 0.99 { Vec3::Z } else { Vec3::Y };
        // look_to, not look_at(position + dir): far from the origin, position + dir rounds
        // the unit direction by ulp(|position|), more than a narrow cone's width.
        let view = Mat4::look_to_rh(light.position, dir, up);
        let proj = Mat4::perspective_rh(light.fov_deg.to_radians(), 1.0, near, far);
        Self::framed(light, light.position, view, proj, (near, far), None)
    }

    fn framed(
        light: &Light,
        position: Vec3,
        view: Mat4,
        proj: Mat4,
        (near, far): (f32, f32),
        sun: Option<SunView>,
    ) -> Self {
        Self {
            position,
            view,
            proj,
            view_proj: proj * view,
            near,
            far,
            fov_deg: light.fov_deg,
            spot_from_clip: Mat4::IDENTITY,
            depth_span: far - near,
            sun,
        }
    }

    /// A spotlight's map fitted inside its cone: a square frustum of half-angle
    /// atan(`tan_half`) from the light along `dir`, rolled by `up`. `spot_from_clip` carries
    /// its clip coordinates back to the cone's frame (`LightView::new`'s).
    pub fn fitted(light: &Light, dir: Vec3, up: Vec3, tan_half: f32, near: f32, far: f32) -> Self {
        let cone = Self::new(light, near, far);
        let view = Mat4::look_to_rh(light.position, dir, up);
        let fov = 2.0 * tan_half.atan();
        let proj = Mat4::perspective_rh(fov, 1.0, near, far);
        let mut v = Self::framed(light, light.position, view, proj, (near, far), None);
        v.fov_deg = fov.to_degrees();
        // Clip (x, y, _, w) -> view (x t, y t, -w) -> the cone's view -> its clip; built from
        // rotations and scales only, so the light's distance from the origin costs no
        // precision (an inverse of view_proj would).
        let to_view = Mat4::from_cols(
            Vec4::new(tan_half, 0.0, 0.0, 0.0),
            Vec4::new(0.0, tan_half, 0.0, 0.0),
            Vec4::ZERO,
            Vec4::new(0.0, 0.0, -1.0, 0.0),
        );
        let rotate = Mat3::from_mat4(cone.view) * Mat3::from_mat4(view).transpose();
        let tc = (light.fov_deg.to_radians() * 0.5).tan();
        let to_clip = Mat4::from_cols(
            Vec4::new(1.0 / tc, 0.0, 0.0, 0.0),
            Vec4::new(0.0, 1.0 / tc, 0.0, 0.0),
            Vec4::new(0.0, 0.0, 0.0, -1.0),
            Vec4::ZERO,
        );
        v.spot_from_clip = to_clip * Mat4::from_mat3(rotate) * to_view;
        v
    }

    /// A sun's orthographic frame: seen from `eye` along `-light.direction()`, a square of
    /// `2 half_width` centred on the axis through `eye`, depths `near..far` from `eye`.
    pub fn sun(light: &Light, eye: Vec3, half_width: f32, near: f32, far: f32) -> Self {
        let dir = -light.direction();
        let up = if dir.y.abs() > 0.99 { Vec3::Z } else { Vec3::Y };
        let view = Mat4::look_to_rh(eye, dir, up);
        let h = half_width;
        let proj = Mat4::orthographic_rh(-h, h, -h, h, near, far);
        let angle = light.sun_angle_deg().unwrap_or(0.0);
        let sun = SunView {
            half_width,
            tan_angle: angle.to_radians().tan(),
        };
        Self::framed(light, eye, view, proj, (near, far), Some(sun))
    }

    /// World size of one of `res` texels across the map at linear depth `depth` (the same
    /// at every depth for a sun).
    pub fn texel_world(&self, depth: f32, res: u32) -> f32 {
        match self.sun {
            Some(s) => 2.0 * s.half_width / res.max(1) as f32,
            None => 2.0 * (self.fov_deg.to_radians() * 0.5).tan() * depth / res.max(1) as f32,
        }
    }

    /// Light-screen uv (in \[0,1\]^2 inside the frustum) and linear depth of a world point.
    pub fn project(&self, p: Vec3) -> (glam::Vec2, f32) {
        let c = self.view_proj * p.extend(1.0);
        let ndc = c.truncate().truncate() / c.w;
        let depth = if self.sun.is_some() {
            self.linear_depth(p)
        } else {
            c.w
        };
        (ndc * 0.5 + glam::Vec2::splat(0.5), depth)
    }

    /// Linear depth of a world point (distance along the light's view axis).
    pub fn linear_depth(&self, p: Vec3) -> f32 {
        -(self.view * p.extend(1.0)).z
    }
}

impl Mesh {
    pub fn triangle_count(&self) -> usize {
        self.indices.len() / 3
    }

    /// Recomputes per-vertex normals as the area-weighted sum of the adjacent triangles'
    /// normals (the cross product's length is twice the area, so no explicit weights).
    /// A vertex with no usable triangle gets +Y rather than NaN.
    pub fn compute_normals(&mut self) {
        let mut acc = vec![Vec3::ZERO; self.positions.len()];
        for t in self.indices.chunks_exact(3) {
            let [a, b, c] = [t[0] as usize, t[1] as usize, t[2] as usize];
            let (Some(&pa), Some(&pb), Some(&pc)) = (
                self.positions.get(a),
                self.positions.get(b),
                self.positions.get(c),
            ) else {
                continue;
            };
            let n = (pb - pa).cross(pc - pa);
            acc[a] += n;
            acc[b] += n;
            acc[c] += n;
        }
        self.normals = acc.into_iter().map(|n| n.normalize_or(Vec3::Y)).collect();
    }

    /// Object-space bounds of the referenced vertices (empty for an empty mesh).
    pub fn bounds(&self) -> Aabb {
        Aabb::from_points(
            self.indices
                .iter()
                .filter_map(|&i| self.positions.get(i as usize).copied()),
        )
    }

    /// Appends `other` transformed by `transform` (normals by its inverse transpose), so
    /// many parts can be merged into one object and one draw.
    pub fn append(&mut self, other: &Mesh, transform: Mat4) {
        let base = self.positions.len() as u32;
        let nm = normal_matrix(transform);
        self.positions.extend(
            other
                .positions
                .iter()
                .map(|&p| transform.transform_point3(p)),
        );
        self.normals.extend(
            other
                .normals
                .iter()
                .map(|&n| (nm * n).normalize_or(Vec3::Y)),
        );
        self.indices.extend(other.indices.iter().map(|&i| i + base));
    }

    /// Checks what renderers rely on: whole triangles, indices in range, one normal per
    /// position, finite numbers. `what` names the mesh in the error.
    pub fn validate(&self, what: &str) -> Result<()> {
        if self.indices.is_empty() {
            bail!("{what}: mesh has no triangles");
        }
        if !self.indices.len().is_multiple_of(3) {
            bail!(
                "{what}: index count {} is not a multiple of 3",
                self.indices.len()
            );
        }
        if self.normals.len() != self.positions.len() {
            bail!(
                "{what}: {} normals for {} positions",
                self.normals.len(),
                self.positions.len()
            );
        }
        if let Some((k, &i)) = self
            .indices
            .iter()
            .enumerate()
            .find(|(_, &i)| i as usize >= self.positions.len())
        {
            bail!(
                "{what}: triangle {} uses vertex {i}, but there are only {} vertices",
                k / 3,
                self.positions.len()
            );
        }
        if let Some(i) = self.positions.iter().position(|p| !p.is_finite()) {
            bail!(
                "{what}: vertex {i} has a non-finite coordinate ({})",
                self.positions[i]
            );
        }
        if let Some(i) = self.normals.iter().position(|n| !n.is_finite()) {
            bail!("{what}: normal {i} is not finite ({})", self.normals[i]);
        }
        Ok(())
    }
}

/// The matrix that carries normals through `m` (inverse transpose of its linear part).
pub fn normal_matrix(m: Mat4) -> Mat3 {
    Mat3::from_mat4(m).inverse().transpose()
}

impl Object {
    pub fn new(
        name: impl Into<String>,
        mesh: Arc<Mesh>,
        transform: Mat4,
        role: Role,
        albedo: Vec3,
    ) -> Self {
        Self {
            name: name.into(),
            mesh,
            transform,
            role,
            albedo,
            bounds: BoundsCache::default(),
        }
    }

    /// World-space bounds: the exact bounds of the transformed vertices (tighter than
    /// transforming the object-space box). Cached until the transform or the mesh changes.
    pub fn world_bounds(&self) -> Aabb {
        // Bits, not ==: -0.0 and 0.0 may give bounds that differ in the sign of a zero.
        let key = self.transform.to_cols_array().map(f32::to_bits);
        if let Some(b) = self.bounds.get(&key, &self.mesh) {
            return b;
        }
        let m = &self.mesh;
        let b = Aabb::from_points(
            m.indices
                .iter()
                .filter_map(|&i| m.positions.get(i as usize))
                .map(|&p| self.transform.transform_point3(p)),
        );
        self.bounds.set(key, &self.mesh, b);
        b
    }

    /// The object's triangles in world space.
    pub fn world_triangles(&self) -> impl Iterator<Item = [Vec3; 3]> + '_ {
        let m = &self.mesh;
        m.indices.chunks_exact(3).filter_map(move |t| {
            let p = |k: usize| {
                m.positions
                    .get(t[k] as usize)
                    .map(|&p| self.transform.transform_point3(p))
            };
            Some([p(0)?, p(1)?, p(2)?])
        })
    }
}

impl Aabb {
    /// The empty box (min = +inf, max = -inf): the identity of `union`.
    pub const EMPTY: Aabb = Aabb {
        min: Vec3::INFINITY,
        max: Vec3::NEG_INFINITY,
    };

    pub fn new(min: Vec3, max: Vec3) -> Self {
        Self { min, max }
    }

    pub fn from_points(points: impl IntoIterator<Item = Vec3>) -> Self {
        points.into_iter().fold(Self::EMPTY, |b, p| b.including(p))
    }

    pub fn is_empty(&self) -> bool {
        !(self.min.cmple(self.max).all())
    }

    pub fn including(self, p: Vec3) -> Self {
        Self {
            min: self.min.min(p),
            max: self.max.max(p),
        }
    }

    pub fn union(self, other: Aabb) -> Self {
        Self {
            min: self.min.min(other.min),
            max: self.max.max(other.max),
        }
    }

    pub fn center(&self) -> Vec3 {
        (self.min + self.max) * 0.5
    }

    /// Size along each axis (max - min).
    pub fn extent(&self) -> Vec3 {
        self.max - self.min
    }

    /// Half the diagonal: the radius of a sphere around `center` that holds the box.
    pub fn radius(&self) -> f32 {
        self.extent().length() * 0.5
    }

    pub fn corners(&self) -> [Vec3; 8] {
        let (a, b) = (self.min, self.max);
        [
            Vec3::new(a.x, a.y, a.z),
            Vec3::new(b.x, a.y, a.z),
            Vec3::new(a.x, b.y, a.z),
            Vec3::new(b.x, b.y, a.z),
            Vec3::new(a.x, a.y, b.z),
            Vec3::new(b.x, a.y, b.z),
            Vec3::new(a.x, b.y, b.z),
            Vec3::new(b.x, b.y, b.z),
        ]
    }

    /// Bounds of this box after `m` (the box of its transformed corners).
    pub fn transform(&self, m: &Mat4) -> Aabb {
        if self.is_empty() {
            return *self;
        }
        Aabb::from_points(self.corners().map(|c| m.transform_point3(c)))
    }
}

/// Smallest scene bounding radius (docs/CLI.md "Numeric range": stress `scene-1e-5`).
pub const MIN_SCENE_RADIUS: f32 = 1e-5;
/// Largest scene bounding radius (docs/CLI.md "Numeric range": stress `scene-2e7`).
pub const MAX_SCENE_RADIUS: f32 = 2e7;

/// Widest light cone (docs/CLI.md "Numeric range": measured with `stress`).
pub const MAX_LIGHT_FOV_DEG: f32 = 120.0;

impl Scene {
    /// Loads a scene by spec: a built-in name (see [`BUILTIN_SCENES`]), else a `.toml`
    /// scene file, a `.gltf`/`.glb` scene, or a `.obj` file framed on a ground plane under a
    /// default light and camera. The result is validated.
    pub fn load(spec: &str) -> Result<Scene> {
        Self::load_with(spec, &LoadOptions::default())
    }

    /// [`Scene::load`] with `opts` saying how far a scene file may reach for the files it
    /// names (by default only inside its own folder; see [`LoadOptions`]).
    pub fn load_with(spec: &str, opts: &LoadOptions) -> Result<Scene> {
        let shown_spec = input::shown_path(Path::new(spec));
        let scene = if let Some(s) = builtin::builtin(spec)? {
            s
        } else {
            let path = Path::new(spec);
            let ext = path
                .extension()
                .and_then(|e| e.to_str())
                .map(|e| e.to_ascii_lowercase());
            match ext.as_deref() {
                Some("toml") => file::load_toml(path, opts)?,
                Some("gltf") | Some("glb") => gltf_io::load_gltf(path, opts)?,
                Some("obj") => builtin::framed_obj(path)?,
                _ if path.is_file() => {
                    bail!("{shown_spec}: not a scene file (expected a .toml or .gltf/.glb scene or a .obj mesh)")
                }
                _ => bail!(
                    "unknown scene '{shown_spec}': not a built-in ({}) nor a .toml/.gltf/.glb/.obj file",
                    BUILTIN_SCENES.join(", ")
                ),
            }
        };
        let bare_obj = builtin::builtin(spec)?.is_none()
            && Path::new(spec)
                .extension()
                .is_some_and(|e| e.eq_ignore_ascii_case("obj"));
        if let Err(e) = scene.validate() {
            // The loader added the ground under a bare OBJ: the user never named it.
            let ground = format!("object '{}'", builtin::FRAMED_GROUND);
            let text = format!("{e:#}");
            if bare_obj && text.contains(&ground) {
                bail!(
                    "{shown_spec}: the ground plane the loader adds under a bare OBJ (sized from the mesh's bounds) is invalid: {}",
                    text.replace(&format!("scene '{}', {ground}: ", input::shown(&scene.name)), "")
                );
            }
            return Err(e);
        }
        Ok(scene)
    }

    /// World bounds of every object.
    pub fn bounds(&self) -> Aabb {
        self.objects
            .iter()
            .fold(Aabb::EMPTY, |b, o| b.union(o.world_bounds()))
    }

    /// World bounds of the objects that cast shadows, `None` when none does.
    pub fn caster_bounds(&self) -> Option<Aabb> {
        let b = self
            .objects
            .iter()
            .filter(|o| o.role.casts())
            .fold(Aabb::EMPTY, |b, o| b.union(o.world_bounds()));
        (!b.is_empty()).then_some(b)
    }

    pub fn triangle_count(&self) -> usize {
        self.objects.iter().map(|o| o.mesh.triangle_count()).sum()
    }

    /// Every triangle in world space, optionally only those of casters (for ray casting
    /// the reference and for outside tools).
    pub fn world_triangles(&self, casters_only: bool) -> Vec<[Vec3; 3]> {
        let mut out = Vec::with_capacity(self.triangle_count());
        for o in &self.objects {
            if !casters_only || o.role.casts() {
                out.extend(o.world_triangles());
            }
        }
        out
    }

    /// Checks everything a renderer assumes: finite numbers everywhere, at least one
    /// caster and one receiver, a light radius >= 0, fields of view in (0, 180), a light
    /// and camera that look somewhere.
    pub fn validate(&self) -> Result<()> {
        let name = &input::shown(&self.name);
        if self.objects.is_empty() {
            bail!("scene '{name}': no objects");
        }
        let triangles = self.triangle_count();
        if triangles > input::MAX_SCENE_TRIANGLES {
            bail!(
                "scene '{name}': {triangles} triangles is above the limit of {} per scene",
                input::MAX_SCENE_TRIANGLES
            );
        }
        for o in &self.objects {
            let what = format!("scene '{name}', object '{}'", input::shown(&o.name));
            o.mesh.validate(&what)?;
            if !o.transform.is_finite() {
                bail!("{what}: transform is not finite");
            }
            if o.transform.determinant().abs() <= f32::MIN_POSITIVE {
                bail!("{what}: transform is singular (a scale of 0?)");
            }
            if !o.world_triangles().any(|t| !degenerate(&t)) {
                bail!(
                    "{what}: every triangle is degenerate (zero area, or under 1e-30 across, in world space): it can neither cast nor receive a shadow"
                );
            }
            if !o.albedo.is_finite() || o.albedo.min_element() < 0.0 {
                bail!("{what}: albedo {} must be finite and >= 0", o.albedo);
            }
        }
        let size = self.bounds().radius();
        if !(MIN_SCENE_RADIUS..=MAX_SCENE_RADIUS).contains(&size) {
            bail!(
                "scene '{name}': its bounding radius {size:e} is out of range: allowed {MIN_SCENE_RADIUS:e} ..= {MAX_SCENE_RADIUS:e} world units (f32 depth and ray precision; see docs/CLI.md, \"Numeric range\")"
            );
        }
        if !self.objects.iter().any(|o| o.role.casts()) {
            bail!("scene '{name}': no object casts shadows (role caster or both)");
        }
        if !self.objects.iter().any(|o| o.role.receives()) {
            bail!("scene '{name}': no object receives shadows (role receiver or both)");
        }
        let l = &self.light;
        check_view(name, "light", l.position, l.target, l.fov_deg)?;
        if let Some(a) = l.sun_angle_deg() {
            if !(0.0..=MAX_SUN_ANGLE_DEG).contains(&a) {
                bail!(
                    "scene '{name}': sun angular_radius_deg {a} is out of range: allowed 0 ..= {MAX_SUN_ANGLE_DEG} (a wider disc is a patch of sky, not a sun)"
                );
            }
        }
        if l.fov_deg > MAX_LIGHT_FOV_DEG {
            bail!(
                "scene '{name}': light fov_deg {} is out of range: allowed (0, {MAX_LIGHT_FOV_DEG}] (a wider cone spreads the shadow map over so much that casters get too few texels)",
                l.fov_deg
            );
        }
        if !l.radius.is_finite() || l.radius < 0.0 {
            bail!(
                "scene '{name}': light radius {} must be finite and >= 0",
                l.radius
            );
        }
        let c = &self.camera;
        check_view(name, "camera", c.position, c.target, c.fov_deg)?;
        if !c.up.is_finite() || c.up.cross(c.target - c.position).length_squared() <= 1e-12 {
            bail!(
                "scene '{name}': camera up {} must be finite and not parallel to the view direction",
                c.up
            );
        }
        Ok(())
    }
}

/// The command line's light overrides: `--light-angle` sets a sun's angular radius;
/// `--light-radius` (applied later, through `Settings::light_radius`) is a spotlight's only.
/// Each is refused, with one line naming the other, for the wrong kind of light.
pub fn apply_light_flags(
    scene: &mut Scene,
    light_radius: Option<f32>,
    light_angle: Option<f32>,
) -> Result<()> {
    let name = input::shown(&scene.name);
    match (&mut scene.light.kind, light_radius, light_angle) {
        (LightKind::Sun { .. }, Some(_), _) => bail!(
            "--light-radius does not apply to scene '{name}': its light is a sun, which has an angular radius: use --light-angle DEGREES"
        ),
        (LightKind::Spot, _, Some(_)) => bail!(
            "--light-angle does not apply to scene '{name}': its light is a spotlight, which has a radius: use --light-radius R"
        ),
        (LightKind::Sun { angular_radius_deg }, None, Some(a)) => {
            if !(0.0..=MAX_SUN_ANGLE_DEG).contains(&a) {
                bail!("--light-angle {a} is out of range: allowed 0 ..= {MAX_SUN_ANGLE_DEG} degrees");
            }
            *angular_radius_deg = a;
        }
        _ => {}
    }
    Ok(())
}

/// Whether a world triangle has no usable area at f32 precision: an edge under 1e-30 (denormal
/// territory, where rasterisers and the ray caster's epsilons give up) or a cross product that
/// vanishes against its longest edge (collinear corners).
pub fn degenerate(t: &[Vec3; 3]) -> bool {
    let [a, b, c] = t.map(|p| p.as_dvec3());
    let longest = (b - a).length().max((c - a).length()).max((c - b).length());
    longest < 1e-30 || (b - a).cross(c - a).length() <= 1e-9 * longest * longest
}

fn check_view(scene: &str, what: &str, position: Vec3, target: Vec3, fov_deg: f32) -> Result<()> {
    if !position.is_finite() || !target.is_finite() {
        bail!("scene '{scene}': {what} position {position} and target {target} must be finite");
    }
    if (target - position).length_squared() <= 1e-12 {
        bail!("scene '{scene}': {what} target equals its position {position}");
    }
    if !(fov_deg > 0.0 && fov_deg < 180.0) {
        bail!("scene '{scene}': {what} fov_deg {fov_deg} must be in (0, 180)");
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn uncached(o: &Object) -> Aabb {
        Aabb::from_points(o.world_triangles().flatten())
    }

    #[test]
    fn cached_world_bounds_follow_the_transform_and_the_mesh() {
        let mut o = Object::new(
            "box",
            Arc::new(primitives::cuboid(Vec3::new(1.0, 2.0, 3.0))),
            Mat4::from_translation(Vec3::X),
            Role::Both,
            Vec3::ONE,
        );
        let first = o.world_bounds();
        assert_eq!(first, uncached(&o));
        assert_eq!(o.world_bounds(), first, "cached");
        o.transform = Mat4::from_rotation_y(0.7) * o.transform;
        assert_ne!(o.world_bounds(), first, "a moved object has new bounds");
        assert_eq!(o.world_bounds(), uncached(&o));
        // A clone carries the cache and still follows its own transform.
        let mut c = o.clone();
        c.transform = Mat4::from_scale(Vec3::splat(2.0));
        assert_eq!(c.world_bounds(), uncached(&c));
        assert_eq!(o.world_bounds(), uncached(&o));
        // Same transform, another mesh.
        let before = o.world_bounds();
        o.mesh = Arc::new(primitives::sphere(0.5, 8, 4));
        assert_ne!(o.world_bounds(), before);
        assert_eq!(o.world_bounds(), uncached(&o));
    }
}
