//! glTF 2.0 scenes (`.gltf`, `.glb`) in and out, through the `gltf` crate. The mapping,
//! documented for users in docs/SCENES.md:
//!
//! - every triangle primitive of every mesh reached from the scene's nodes is one object,
//!   placed by the node's world transform (the product of its ancestors' transforms);
//! - roles come from node extras `{"softshadow": {"role": "caster"|"receiver"|"both"}}`, a
//!   node without one takes its nearest ancestor's, the default is `both`;
//! - the albedo is the material's `baseColorFactor` (RGB), 0.8 grey without a material;
//! - the light is the first KHR_lights_punctual spot light met depth first: its node's world
//!   position, its -Z axis, a field of view of twice `outerConeAngle`, and the radius from
//!   the light's extras `{"softshadow": {"radius": R}}`, else the scene-size default
//!   (`--light-radius` overrides both); without a spot light, the first point light gives
//!   the position and the aim and cone are fitted; without either, the first directional
//!   light is a sun shining along its node's -Z axis, its angular radius from extras
//!   `{"softshadow": {"angular_radius_deg": A}}`, else 1 degree (`--light-angle` overrides
//!   both); without any, the default light;
//! - the camera is the first perspective camera met depth first (`yfov`, the node's -Z
//!   axis, its +Y as up); without one, the default framing.
//!
//! Compressed geometry (Draco, meshopt, KHR_mesh_quantization's integer attributes) is
//! decoded by `gltf_decode` before it is read.
//!
//! Refused with one error line: skins, morph targets, sparse accessors, point and line
//! primitives, positions and normals that are neither float nor a quantized form, a
//! required extension neither the `gltf` crate nor `gltf_decode` knows (GPU instancing).
//! Textures and every material field but the base colour factor are ignored: shadows need
//! only geometry.
//!
//! Export writes the scene back as glTF: one node per object (its transform as `matrix`,
//! its role in extras), a mesh per distinct mesh and albedo, the light as a KHR spot light
//! with its radius in extras (a sun as a directional light with its angular radius), and
//! the camera. `.glb` is one file; `.gltf` writes its buffer
//! to a `.bin` beside it.

use super::gltf_decode::{self, Compressed, Draco};
use super::input::{self, LoadOptions};
use super::{builtin, Aabb, Camera, Light, Mesh, Object, Role, Scene, MAX_LIGHT_FOV_DEG};
use anyhow::{anyhow, bail, Context, Result};
use glam::{Mat3, Mat4, Quat, Vec3};
use serde_json::{json, Value};
use std::collections::HashMap;
use std::path::Path;
use std::sync::Arc;

/// How far along its direction an imported sun's `Light::position` sits, in scene sizes (as
/// for TOML scenes): a point for the default camera's framing and exports only.
const SUN_RIG_DISTANCE: f32 = 4.0;

/// The extras key under which softshadow keeps its own fields.
const EXTRAS_KEY: &str = "softshadow";

/// Deepest node hierarchy walked: far beyond any exported scene, and a clear error for a
/// file built to exhaust the walk.
pub const MAX_NODE_DEPTH: usize = 1000;

/// Deepest JSON nesting read. Extras may nest deeper than the JSON parser's own limit;
/// beyond this a file is refused before it is parsed.
pub const MAX_JSON_DEPTH: usize = 1000;

/// Nesting the JSON parser takes without help (serde_json stops at 128).
const PLAIN_JSON_DEPTH: usize = 100;

/// Loads a `.gltf` or `.glb` file (see the module docs); external buffers are resolved
/// against the file's folder and, unless `opts` allows otherwise, must lie inside it.
pub fn load_gltf(path: &Path, opts: &LoadOptions) -> Result<Scene> {
    let name = input::shown_path(path);
    let bytes = input::read_file(path, &name)?;
    let stem = path
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "scene".into());
    let dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
    parse_gltf_with(&bytes, &name, &stem, Some(&dir), opts)
}

/// Parses glTF or GLB bytes. `file` labels errors, `stem` is the default scene name and
/// `dir` the folder external buffers are read from (`None`: data URIs and the GLB blob only).
pub fn parse_gltf(bytes: &[u8], file: &str, stem: &str, dir: Option<&Path>) -> Result<Scene> {
    parse_gltf_with(bytes, file, stem, dir, &LoadOptions::default())
}

/// [`parse_gltf`] with the options of [`LoadOptions`].
pub fn parse_gltf_with(
    bytes: &[u8],
    file: &str,
    stem: &str,
    dir: Option<&Path>,
    opts: &LoadOptions,
) -> Result<Scene> {
    // Everything the gltf crate is known to panic on is checked before it is asked; this
    // is the last line of defence for the unknown.
    let parsed = std::panic::catch_unwind(|| parse_unwinding(bytes, file, stem, dir, opts));
    match parsed {
        Ok(r) => r,
        Err(_) => bail!("{file}: malformed glTF (the parser failed)"),
    }
}

/// The deepest nesting of `[` and `{` in JSON text, strings skipped.
fn json_depth(text: &[u8]) -> usize {
    let (mut depth, mut max, mut in_string, mut escaped) = (0usize, 0usize, false, false);
    for &c in text {
        if in_string {
            if escaped {
                escaped = false;
            } else if c == b'\\' {
                escaped = true;
            } else if c == b'"' {
                in_string = false;
            }
            continue;
        }
        match c {
            b'"' => in_string = true,
            b'[' | b'{' => {
                depth += 1;
                max = max.max(depth);
            }
            b']' | b'}' => depth = depth.saturating_sub(1),
            _ => {}
        }
    }
    max
}

/// Keeps of every `extras` only softshadow's own key and of every `extensions` only
/// KHR_lights_punctual and the compression extensions: the rest is never read, and may
/// nest deeper than the parser goes.
fn prune(v: &mut Value) {
    match v {
        Value::Object(m) => {
            match m.get_mut("extras") {
                Some(Value::Object(x)) => x.retain(|k, _| k == EXTRAS_KEY),
                Some(_) => {
                    m.remove("extras");
                }
                None => {}
            }
            if let Some(Value::Object(e)) = m.get_mut("extensions") {
                e.retain(|k, _| {
                    k == "KHR_lights_punctual"
                        || gltf_decode::DECODED_EXTENSIONS.contains(&k.as_str())
                });
            }
            m.values_mut().for_each(prune);
        }
        Value::Array(a) => a.iter_mut().for_each(prune),
        _ => {}
    }
}

/// The glTF JSON as the gltf crate can read it: unchanged when shallow, else parsed on a
/// thread with room for the recursion, pruned (`prune`) and written back.
fn shallow_json<'a>(json: &'a [u8], file: &str) -> Result<std::borrow::Cow<'a, [u8]>> {
    let depth = json_depth(json);
    if depth <= PLAIN_JSON_DEPTH {
        return Ok(json.into());
    }
    if depth > MAX_JSON_DEPTH {
        bail!("{file}: its JSON nests {depth} levels deep, above the limit of {MAX_JSON_DEPTH}");
    }
    let pruned = std::thread::scope(|s| {
        std::thread::Builder::new()
            .stack_size(256 << 20)
            .spawn_scoped(s, || -> Result<Vec<u8>> {
                use serde::Deserialize;
                let mut de = serde_json::Deserializer::from_slice(json);
                de.disable_recursion_limit();
                let mut v = Value::deserialize(&mut de)
                    .map_err(|e| anyhow!("{file}: not a valid glTF file: {}", one_line(&e)))?;
                prune(&mut v);
                Ok(serde_json::to_vec(&v)?)
            })
            .map(|t| t.join())
    });
    match pruned {
        Ok(Ok(r)) => Ok(r?.into()),
        _ => bail!("{file}: malformed glTF (the parser failed)"),
    }
}

fn parse_unwinding(
    bytes: &[u8],
    file: &str,
    stem: &str,
    dir: Option<&Path>,
    opts: &LoadOptions,
) -> Result<Scene> {
    let (json, blob) = if bytes.starts_with(b"glTF") {
        let glb = gltf::Glb::from_slice(bytes)
            .map_err(|e| anyhow!("{file}: not a valid glTF file (GLB): {}", one_line(&e)))?;
        (glb.json, glb.bin.map(|b| b.into_owned()))
    } else {
        (bytes.into(), None)
    };
    let json = shallow_json(&json, file)?;
    let gltf::Gltf { document, .. } = gltf::Gltf::from_slice_without_validation(&json)
        .map_err(|e| anyhow!("{file}: not a valid glTF file: {}", one_line(&e)))?;
    let mut root = document.into_json();
    // Named here: the crate's validation only says "unsupported". Extensions that change
    // only the look of materials do not matter to shadows and are dropped.
    root.extensions_required
        .retain(|e| !appearance_only(e) && !gltf_decode::DECODED_EXTENSIONS.contains(&e.as_str()));
    let compressed = Compressed::scan(&root, file)?;
    compressed.stand_in_views(&mut root);
    if let Some(ext) = root
        .extensions_required
        .iter()
        .find(|e| !gltf::json::extensions::ENABLED_EXTENSIONS.contains(&e.as_str()))
    {
        bail!(
            "{file}: requires the glTF extension {}, which softshadow does not support",
            input::shown(ext)
        );
    }
    let doc =
        gltf::Document::from_json(root).map_err(|e| anyhow!("{file}: {}", few(&one_line(&e))))?;
    let doc = &doc;
    check_hierarchy(doc, file)?;
    let scene = doc
        .default_scene()
        .or_else(|| doc.scenes().next())
        .ok_or_else(|| anyhow!("{file}: has no scene"))?;
    check_declared_sizes(&scene, &compressed, file)?;
    let buffers = load_buffers(doc, &compressed, dir, blob, file, opts)?;

    let mut walk = Walk {
        file,
        buffers: &buffers,
        compressed: &compressed,
        meshes: HashMap::new(),
        objects: Vec::new(),
        spot: None,
        point: None,
        sun: None,
        camera: None,
    };
    // Depth first, parents before children, children in file order: an explicit stack,
    // so that the depth of a file's hierarchy is bounded by a limit, not by the thread's stack.
    let mut stack: Vec<(gltf::Node, Mat4, Role, usize)> = scene
        .nodes()
        .map(|n| (n, Mat4::IDENTITY, Role::Both, 1))
        .collect();
    stack.reverse();
    while let Some((node, parent, parent_role, depth)) = stack.pop() {
        if depth > MAX_NODE_DEPTH {
            bail!(
                "{file}: {}: the node hierarchy is more than {MAX_NODE_DEPTH} levels deep, the limit",
                node_label(&node)
            );
        }
        let (world, role) = walk.node(&node, parent, parent_role)?;
        let children: Vec<gltf::Node> = node.children().collect();
        stack.extend(
            children
                .into_iter()
                .rev()
                .map(|c| (c, world, role, depth + 1)),
        );
    }
    let Walk {
        objects,
        spot,
        point,
        sun,
        camera,
        ..
    } = walk;
    if objects.is_empty() {
        bail!("{file}: the scene has no triangle meshes");
    }

    // Defaults as for TOML files and bare OBJs: fitted to the casters and their shadow.
    let bounds = objects
        .iter()
        .fold(Aabb::EMPTY, |b, o| b.union(o.world_bounds()));
    let ground_y = bounds.min.y;
    let size = bounds.extent().max_element().max(1e-3);
    let centre = bounds.center();
    // A sun's position is only a point on its axis, for the default camera's framing.
    let sun = sun.filter(|_| spot.is_none() && point.is_none());
    let light_pos = match (&spot, &point, &sun) {
        (Some(s), _, _) => s.position,
        (None, Some(p), _) => *p,
        (None, None, Some(s)) => centre + s.direction * (SUN_RIG_DISTANCE * size),
        (None, None, None) => centre + Vec3::new(-1.2, 2.5, 0.8) * size,
    };
    let (auto_light, auto_camera) = builtin::rig(
        &objects,
        light_pos,
        ground_y,
        0.04,
        Vec3::new(0.4, 0.6, 1.0),
    );
    let light = match (spot, sun) {
        (None, Some(s)) => Light::sun(
            s.direction,
            centre,
            s.angular_radius_deg.unwrap_or(super::DEFAULT_SUN_ANGLE_DEG),
            SUN_RIG_DISTANCE * size,
        ),
        (Some(s), _) => Light {
            position: s.position,
            target: s.position + s.direction * aim_distance(s.position, s.direction, centre, size),
            fov_deg: s.fov_deg,
            radius: s.radius.unwrap_or(auto_light.radius),
            kind: super::LightKind::Spot,
        },
        (None, None) => auto_light,
    };
    let camera = match camera {
        Some(c) => Camera {
            position: c.position,
            target: c.position + c.forward * aim_distance(c.position, c.forward, centre, size),
            up: c.up,
            fov_deg: c.fov_deg,
        },
        None => auto_camera,
    };
    let scene = Scene {
        name: scene
            .name()
            .map(str::to_owned)
            .unwrap_or_else(|| stem.into()),
        objects,
        light,
        camera,
    };
    scene
        .validate()
        .with_context(|| format!("{file}: invalid scene"))?;
    Ok(scene)
}

/// How far along `dir` from `from` to put a target: the scene centre's depth along it,
/// at least a tenth of the scene's size so the target never sits on the eye.
fn aim_distance(from: Vec3, dir: Vec3, centre: Vec3, size: f32) -> f32 {
    (centre - from).dot(dir).max(size * 0.1)
}

/// Required extensions that change only how materials look, which shadows ignore.
fn appearance_only(ext: &str) -> bool {
    ext.starts_with("KHR_materials_")
        || matches!(
            ext,
            "KHR_texture_transform"
                | "KHR_texture_basisu"
                | "EXT_texture_webp"
                | "EXT_texture_avif"
        )
}

/// The first few of a validation's `; `-separated findings: a file with thousands of bad
/// fields gives one readable line.
fn few(findings: &str) -> String {
    const SHOWN: usize = 3;
    let all: Vec<&str> = findings
        .split("; ")
        .map(str::trim)
        .filter(|f| !f.is_empty())
        .collect();
    if all.len() <= SHOWN {
        return findings.trim_end_matches(';').to_owned();
    }
    format!(
        "{}; and {} more",
        all[..SHOWN].join("; ").trim_end_matches(';'),
        all.len() - SHOWN
    )
}

/// A library error on one line (the crate's messages may span several).
fn one_line(e: &dyn std::fmt::Display) -> String {
    e.to_string().replace('\n', " ").trim().to_owned()
}

struct Spot {
    position: Vec3,
    direction: Vec3,
    fov_deg: f32,
    radius: Option<f32>,
}

/// A directional light: its direction towards the light, its angular radius from extras.
struct SunSpec {
    direction: Vec3,
    angular_radius_deg: Option<f32>,
}

struct Eye {
    position: Vec3,
    forward: Vec3,
    up: Vec3,
    fov_deg: f32,
}

/// The depth-first walk over a scene's node tree.
struct Walk<'a> {
    file: &'a str,
    buffers: &'a [gltf::buffer::Data],
    compressed: &'a Compressed,
    /// One mesh per distinct mode and POSITION, NORMAL and indices data (`PrimitiveKey`),
    /// shared by every node and every glTF mesh that use the same data.
    meshes: HashMap<PrimitiveKey, Arc<Mesh>>,
    objects: Vec<Object>,
    spot: Option<Spot>,
    point: Option<Vec3>,
    sun: Option<SunSpec>,
    camera: Option<Eye>,
}

impl Walk<'_> {
    /// One node: its mesh, light and camera. Returns its world transform and role, which
    /// its children inherit.
    fn node(&mut self, node: &gltf::Node, parent: Mat4, parent_role: Role) -> Result<(Mat4, Role)> {
        let file = self.file;
        let label = node_label(node);
        let world = parent * local_transform(node).with_context(|| format!("{file}: {label}"))?;
        let role = match role_extra(node.extras()).with_context(|| format!("{file}: {label}"))? {
            Some(r) => r,
            None => parent_role,
        };
        if node.skin().is_some() {
            bail!("{file}: {label}: skinned meshes are not supported (apply the skin first)");
        }
        if let Some(mesh) = node.mesh() {
            self.mesh(node, &mesh, world, role, &label)?;
        }
        if let Some(light) = node.light() {
            let position = world.transform_point3(Vec3::ZERO);
            match light.kind() {
                gltf::khr_lights_punctual::Kind::Spot {
                    outer_cone_angle, ..
                } if self.spot.is_none() => {
                    let direction = axis(&world, Vec3::NEG_Z).ok_or_else(|| {
                        anyhow!("{file}: {label}: the spot light's node transform has no direction (a scale of 0?)")
                    })?;
                    let fov_deg = outer_cone_angle.to_degrees() * 2.0;
                    if !(fov_deg > 0.0 && fov_deg <= MAX_LIGHT_FOV_DEG) {
                        bail!(
                            "{file}: {label}: spot light outerConeAngle {outer_cone_angle} rad ({:.1} degrees) is out of range: allowed (0, {:.4}] rad, a cone of at most {MAX_LIGHT_FOV_DEG} degrees (a wider one spreads the shadow map over so much that casters get too few texels)",
                            outer_cone_angle.to_degrees(),
                            (MAX_LIGHT_FOV_DEG * 0.5).to_radians()
                        );
                    }
                    let radius = light_radius_extra(light.extras())
                        .with_context(|| format!("{file}: {label}: light"))?;
                    self.spot = Some(Spot {
                        position,
                        direction,
                        fov_deg,
                        radius,
                    });
                }
                gltf::khr_lights_punctual::Kind::Directional if self.sun.is_none() => {
                    let travel = axis(&world, Vec3::NEG_Z).ok_or_else(|| {
                        anyhow!("{file}: {label}: the directional light's node transform has no direction (a scale of 0?)")
                    })?;
                    let angular_radius_deg = sun_angle_extra(light.extras())
                        .with_context(|| format!("{file}: {label}: light"))?;
                    self.sun = Some(SunSpec {
                        direction: -travel,
                        angular_radius_deg,
                    });
                }
                gltf::khr_lights_punctual::Kind::Point if self.point.is_none() => {
                    self.point = Some(position);
                }
                _ => {}
            }
        }
        if let (Some(cam), None) = (node.camera(), &self.camera) {
            if let gltf::camera::Projection::Perspective(p) = cam.projection() {
                let (Some(forward), Some(up)) = (axis(&world, Vec3::NEG_Z), axis(&world, Vec3::Y))
                else {
                    bail!("{file}: {label}: the camera's node transform has no direction (a scale of 0?)");
                };
                self.camera = Some(Eye {
                    position: world.transform_point3(Vec3::ZERO),
                    forward,
                    up,
                    fov_deg: p.yfov().to_degrees(),
                });
            }
        }
        Ok((world, role))
    }

    fn mesh(
        &mut self,
        node: &gltf::Node,
        mesh: &gltf::Mesh,
        world: Mat4,
        role: Role,
        label: &str,
    ) -> Result<()> {
        let file = self.file;
        let mesh_label = match mesh.name() {
            Some(n) => format!("mesh {} ('{}')", mesh.index(), input::shown(n)),
            None => format!("mesh {}", mesh.index()),
        };
        let base_name = node
            .name()
            .or(mesh.name())
            .map(str::to_owned)
            .unwrap_or_else(|| format!("node{}", node.index()));
        let count = mesh.primitives().len();
        for prim in mesh.primitives() {
            let what = format!("{file}: {label}, {mesh_label}, primitive {}", prim.index());
            // Sizes were bounded by `check_declared_sizes` before any buffer was loaded.
            let draco = self.compressed.draco(mesh.index(), prim.index());
            let key = primitive_key(&prim, draco);
            let m = match self.meshes.get(&key) {
                Some(m) => m.clone(),
                None => {
                    let m = Arc::new(read_primitive(&prim, draco, self.buffers, &what)?);
                    self.meshes.insert(key, m.clone());
                    m
                }
            };
            let albedo = prim.material().pbr_metallic_roughness().base_color_factor();
            let albedo = if prim.material().index().is_some() {
                Vec3::new(albedo[0], albedo[1], albedo[2])
            } else {
                Vec3::splat(0.8)
            };
            let name = if count == 1 {
                base_name.clone()
            } else {
                format!("{base_name}.{}", prim.index())
            };
            self.objects.push(Object::new(name, m, world, role, albedo));
        }
        Ok(())
    }
}

fn node_label(node: &gltf::Node) -> String {
    match node.name() {
        Some(n) => format!("node {} ('{}')", node.index(), input::shown(n)),
        None => format!("node {}", node.index()),
    }
}

/// The unit direction `world` carries `v` to, computed in f64 so that a tiny but valid
/// scale (1e-30) keeps its direction; `None` when the transform flattens it.
fn axis(world: &Mat4, v: Vec3) -> Option<Vec3> {
    let d = world.as_dmat4().transform_vector3(v.as_dvec3());
    let n = d.normalize_or_zero().as_vec3();
    (n != Vec3::ZERO && n.is_finite()).then_some(n)
}

/// What a primitive's mesh is read from: its mode, its POSITION, NORMAL and indices
/// accessors and its Draco stream (and whether it has morph targets, which
/// `read_primitive` refuses).
type PrimitiveKey = (
    bool,
    u32,
    Option<AccessorKey>,
    Option<AccessorKey>,
    Option<AccessorKey>,
    Option<Draco>,
);

/// Where an accessor's elements come from: buffer view, offset, count, component type and
/// dimensions. Two accessors with the same key read the same values.
type AccessorKey = (usize, usize, usize, u32, usize);

fn accessor_key(a: gltf::Accessor) -> AccessorKey {
    (
        a.view().map_or(usize::MAX, |v| v.index()),
        a.offset(),
        a.count(),
        a.data_type().as_gl_enum(),
        a.dimensions().multiplicity(),
    )
}

fn primitive_key(prim: &gltf::Primitive, draco: Option<Draco>) -> PrimitiveKey {
    (
        prim.morph_targets().len() > 0,
        prim.mode().as_gl_enum(),
        prim.get(&gltf::Semantic::Positions).map(accessor_key),
        prim.get(&gltf::Semantic::Normals).map(accessor_key),
        prim.indices().map(accessor_key),
        draco,
    )
}

/// Bounds the scene's triangles (every instance) and the vertices its distinct meshes read,
/// from declared counts alone, before any buffer is loaded. Needs a forest
/// (`check_hierarchy`): every node is met once.
fn check_declared_sizes(scene: &gltf::Scene, compressed: &Compressed, file: &str) -> Result<()> {
    let (mut triangles, mut vertices) = (0usize, 0usize);
    let mut seen = std::collections::HashSet::new();
    let mut stack: Vec<gltf::Node> = scene.nodes().collect();
    while let Some(node) = stack.pop() {
        if let Some(mesh) = node.mesh() {
            for prim in mesh.primitives() {
                let (t, v) = declared_size(&prim);
                triangles = triangles.saturating_add(t);
                let draco = compressed.draco(mesh.index(), prim.index());
                if seen.insert(primitive_key(&prim, draco)) {
                    vertices = vertices.saturating_add(v);
                }
                let at = || {
                    format!(
                        "{file}: {}, mesh {}, primitive {}",
                        node_label(&node),
                        mesh.index(),
                        prim.index()
                    )
                };
                if triangles > input::MAX_SCENE_TRIANGLES {
                    bail!(
                        "{}: brings the scene to {triangles} triangles (each instance counts), above the limit of {} per scene",
                        at(),
                        input::MAX_SCENE_TRIANGLES
                    );
                }
                if vertices > input::MAX_SCENE_VERTICES {
                    bail!(
                        "{}: brings the scene to {vertices} vertices read, above the limit of {} per scene",
                        at(),
                        input::MAX_SCENE_VERTICES
                    );
                }
            }
        }
        stack.extend(node.children());
    }
    Ok(())
}

/// The triangles a primitive declares (from its index or vertex count and mode) and the
/// vertices its reading allocates, known before any of it is read.
fn declared_size(prim: &gltf::Primitive) -> (usize, usize) {
    use gltf::mesh::Mode;
    let positions = prim
        .get(&gltf::Semantic::Positions)
        .map_or(0, |a| a.count());
    let n = prim.indices().map_or(positions, |a| a.count());
    let triangles = match prim.mode() {
        Mode::TriangleStrip | Mode::TriangleFan => n.saturating_sub(2),
        _ => n / 3,
    };
    // Without normals every triangle gets three vertices of its own (`flat`).
    let normals = prim.get(&gltf::Semantic::Normals).is_some();
    let expanded = if normals {
        0
    } else {
        triangles.saturating_mul(3)
    };
    (triangles, positions.saturating_add(expanded))
}

/// Refuses node graphs that are not forests before anything walks them: a cycle, a node
/// with two parents (or listed twice by one), a scene root that is also a child. glTF
/// requires the nodes to form disjoint trees; expanding a shared child once per parent
/// multiplies the work with each level.
fn check_hierarchy(doc: &gltf::Document, file: &str) -> Result<()> {
    let nodes: Vec<gltf::Node> = doc.nodes().collect();
    let children: Vec<Vec<usize>> = nodes
        .iter()
        .map(|n| n.children().map(|c| c.index()).collect())
        .collect();
    // Cycles: an iterative depth-first search over every node, colouring the path.
    const NEW: u8 = 0;
    const ON_PATH: u8 = 1;
    const DONE: u8 = 2;
    let mut state = vec![NEW; nodes.len()];
    for start in 0..nodes.len() {
        if state[start] != NEW {
            continue;
        }
        let mut path: Vec<(usize, usize)> = vec![(start, 0)];
        state[start] = ON_PATH;
        while let Some(&mut (n, ref mut next)) = path.last_mut() {
            if let Some(&c) = children[n].get(*next) {
                *next += 1;
                match state[c] {
                    NEW => {
                        state[c] = ON_PATH;
                        path.push((c, 0));
                    }
                    ON_PATH => bail!(
                        "{file}: {}: the node hierarchy has a cycle (it is its own ancestor)",
                        node_label(&nodes[c])
                    ),
                    _ => {}
                }
            } else {
                state[n] = DONE;
                path.pop();
            }
        }
    }
    let mut parent: Vec<Option<usize>> = vec![None; nodes.len()];
    for (p, cs) in children.iter().enumerate() {
        for &c in cs {
            if let Some(first) = parent[c] {
                bail!(
                    "{file}: {}: is a child of {} and of {}; glTF requires each node to have at most one parent",
                    node_label(&nodes[c]),
                    node_label(&nodes[first]),
                    if first == p { "it again".to_owned() } else { node_label(&nodes[p]) }
                );
            }
            parent[c] = Some(p);
        }
    }
    for scene in doc.scenes() {
        let mut seen = std::collections::HashSet::new();
        for root in scene.nodes() {
            if let Some(p) = parent[root.index()] {
                bail!(
                    "{file}: scene {}: its root {} is also a child of {}; glTF requires scene roots to be root nodes",
                    scene.index(),
                    node_label(&root),
                    node_label(&nodes[p])
                );
            }
            if !seen.insert(root.index()) {
                bail!(
                    "{file}: scene {}: lists {} twice",
                    scene.index(),
                    node_label(&root)
                );
            }
        }
    }
    Ok(())
}

/// Every buffer's bytes: the GLB blob, a data URI, or a file in the glTF file's folder
/// (outside it only when `opts` allows); a meshopt fallback buffer is zeros until its
/// views are decoded into it. Images are never read: shadows need no textures.
fn load_buffers(
    doc: &gltf::Document,
    compressed: &Compressed,
    dir: Option<&Path>,
    mut blob: Option<Vec<u8>>,
    file: &str,
    opts: &LoadOptions,
) -> Result<Vec<gltf::buffer::Data>> {
    let mut out = Vec::new();
    let mut fallback_bytes = 0u64;
    for buffer in doc.buffers() {
        let label = format!("{file}: buffer {}", buffer.index());
        let mut data = match buffer.source() {
            gltf::buffer::Source::Bin if compressed.is_fallback(buffer.index()) => {
                fallback_bytes = fallback_bytes.saturating_add(buffer.length() as u64);
                if fallback_bytes > input::MAX_FILE_BYTES {
                    bail!(
                        "{label}: meshopt fallback buffers total {fallback_bytes} bytes, above the limit of {} bytes",
                        input::MAX_FILE_BYTES
                    );
                }
                vec![0; buffer.length()]
            }
            gltf::buffer::Source::Bin => blob.take().ok_or_else(|| {
                anyhow!("{label}: has no URI and the file has no GLB binary chunk for it")
            })?,
            gltf::buffer::Source::Uri(uri) => read_uri(uri, dir, &label, opts)?,
        };
        if data.len() < buffer.length() {
            bail!(
                "{label}: holds {} bytes, fewer than its byteLength {}",
                data.len(),
                buffer.length()
            );
        }
        while !data.len().is_multiple_of(4) {
            data.push(0);
        }
        out.push(data);
    }
    compressed.decode_meshopt(&mut out, file)?;
    Ok(out.into_iter().map(gltf::buffer::Data).collect())
}

/// A buffer URI's bytes: `data:` decoded, a relative path (percent-decoded) or a `file:`
/// URI read from `dir`, confined to it unless `opts` allows otherwise.
fn read_uri(uri: &str, dir: Option<&Path>, label: &str, opts: &LoadOptions) -> Result<Vec<u8>> {
    let shown_uri = input::token(uri, 80);
    if uri.starts_with("data:") {
        return gltf::buffer::Data::from_source(gltf::buffer::Source::Uri(uri), None)
            .map(|d| d.0)
            .map_err(|e| anyhow!("{label}: its data URI does not decode: {}", one_line(&e)));
    }
    let path = match uri
        .strip_prefix("file://")
        .or_else(|| uri.strip_prefix("file:"))
    {
        Some(rest) => rest,
        None if uri.contains(':') => bail!(
            "{label}: URI '{shown_uri}' has a scheme softshadow does not read (only relative paths and data: URIs)"
        ),
        None => uri,
    };
    let decoded = urlencoding::decode(path)
        .map_err(|_| anyhow!("{label}: URI '{shown_uri}' is not percent-encoded UTF-8"))?;
    let Some(dir) = dir else {
        bail!("{label}: URI '{shown_uri}' names a file, but these bytes came without a folder");
    };
    let path = input::resolve_inside(dir, Path::new(&*decoded), opts, &format!("{label}: URI"))?;
    input::read_file(&path, &format!("{label}: {}", input::shown_path(&path)))
}

/// The node's own transform: its `matrix`, or translation · rotation · scale.
fn local_transform(node: &gltf::Node) -> Result<Mat4> {
    let m = match node.transform() {
        gltf::scene::Transform::Matrix { matrix } => {
            let m = Mat4::from_cols_array_2d(&matrix);
            // The rasteriser divides by w, the ray caster would not: they would disagree.
            let bottom = m.row(3);
            if (bottom - glam::Vec4::W).abs().max_element() > 1e-6 {
                bail!(
                    "matrix is not affine (its bottom row is {bottom}, not [0, 0, 0, 1]): projective node transforms are not supported"
                );
            }
            m
        }
        gltf::scene::Transform::Decomposed {
            translation,
            rotation,
            scale,
        } => {
            let q = Quat::from_array(rotation);
            if !q.is_finite() || q.length_squared() < 1e-12 {
                bail!("rotation {rotation:?} is not a unit quaternion");
            }
            Mat4::from_scale_rotation_translation(
                Vec3::from(scale),
                q.normalize(),
                Vec3::from(translation),
            )
        }
    };
    if !m.is_finite() {
        bail!("transform is not finite");
    }
    Ok(m)
}

/// `extras.softshadow` as a JSON object, `None` when absent.
fn softshadow_extras(
    extras: &gltf::json::Extras,
) -> Result<Option<serde_json::Map<String, Value>>> {
    let Some(raw) = extras else {
        return Ok(None);
    };
    let v: Value = serde_json::from_str(raw.get()).context("extras are not valid JSON")?;
    match v.get(EXTRAS_KEY) {
        None => Ok(None),
        Some(Value::Object(m)) => Ok(Some(m.clone())),
        Some(other) => bail!("extras.{EXTRAS_KEY} must be an object, not {other}"),
    }
}

fn role_extra(extras: &gltf::json::Extras) -> Result<Option<Role>> {
    let Some(m) = softshadow_extras(extras)? else {
        return Ok(None);
    };
    match m.get("role") {
        None => Ok(None),
        Some(Value::String(s)) => match s.as_str() {
            "caster" => Ok(Some(Role::Caster)),
            "receiver" => Ok(Some(Role::Receiver)),
            "both" => Ok(Some(Role::Both)),
            _ => bail!("extras.{EXTRAS_KEY}.role '{s}' must be caster, receiver or both"),
        },
        Some(v) => bail!("extras.{EXTRAS_KEY}.role must be a string, not {v}"),
    }
}

fn light_radius_extra(extras: &gltf::json::Extras) -> Result<Option<f32>> {
    number_extra(
        extras,
        "radius",
        |r| r.is_finite() && r >= 0.0,
        "a number >= 0",
    )
}

fn sun_angle_extra(extras: &gltf::json::Extras) -> Result<Option<f32>> {
    let max = super::MAX_SUN_ANGLE_DEG;
    number_extra(
        extras,
        "angular_radius_deg",
        |a| (0.0..=max as f64).contains(&a),
        &format!("a number in 0 ..= {max}"),
    )
}

/// The number `extras.softshadow.KEY`, `None` without one; refused unless `ok` (`rule` says
/// what is allowed).
fn number_extra(
    extras: &gltf::json::Extras,
    key: &str,
    ok: impl Fn(f64) -> bool,
    rule: &str,
) -> Result<Option<f32>> {
    let Some(m) = softshadow_extras(extras)? else {
        return Ok(None);
    };
    match m.get(key) {
        None => Ok(None),
        Some(v) => match v.as_f64() {
            Some(x) if ok(x) => Ok(Some(x as f32)),
            _ => bail!("extras.{EXTRAS_KEY}.{key} {v} must be {rule}"),
        },
    }
}

/// One triangle primitive as a mesh in its node's space, from its accessors or, when
/// `draco` names one, its Draco stream.
fn read_primitive(
    prim: &gltf::Primitive,
    draco: Option<Draco>,
    buffers: &[gltf::buffer::Data],
    what: &str,
) -> Result<Mesh> {
    use gltf::accessor::{DataType, Dimensions};
    use gltf::mesh::Mode;
    if prim.morph_targets().len() > 0 {
        bail!("{what}: morph targets are not supported (bake them into the mesh first)");
    }
    let mode = prim.mode();
    if !matches!(
        mode,
        Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan
    ) {
        bail!("{what}: mode {mode:?} is not supported (only triangles, strips and fans have a surface)");
    }
    let pos = prim
        .get(&gltf::Semantic::Positions)
        .ok_or_else(|| anyhow!("{what}: has no POSITION attribute"))?;
    let mut used = vec![("POSITION", pos.clone())];
    if let Some(n) = prim.get(&gltf::Semantic::Normals) {
        used.push(("NORMAL", n));
    }
    if let Some(i) = prim.indices() {
        used.push(("indices", i));
    }
    if let Some(d) = draco {
        let (positions, normals, raw) = read_draco(prim, d, buffers, what)?;
        return finish_primitive(mode, positions, normals, raw, what);
    }
    for (attr, a) in &used {
        if a.sparse().is_some() {
            bail!("{what}: {attr} uses a sparse accessor, which is not supported");
        }
        if a.view().is_none() {
            bail!("{what}: {attr} accessor {} has no buffer view", a.index());
        }
        if a.count() == 0 {
            bail!("{what}: {attr} accessor {} is empty", a.index());
        }
        check_range(a, buffers, what, attr)?;
        let ok = match *attr {
            "indices" => {
                a.dimensions() == Dimensions::Scalar
                    && matches!(a.data_type(), DataType::U8 | DataType::U16 | DataType::U32)
            }
            _ => {
                a.dimensions() == Dimensions::Vec3
                    && gltf_decode::vec3_type_allowed(attr, a.data_type(), a.normalized())
            }
        };
        if !ok {
            bail!(
                "{what}: {attr} accessor {} is {:?} {:?}, expected {}",
                a.index(),
                a.dimensions(),
                a.data_type(),
                match *attr {
                    "indices" => "unsigned integer scalars",
                    "NORMAL" => "VEC3 of float or normalized BYTE/SHORT (KHR_mesh_quantization)",
                    _ => "VEC3 of float or (normalized) BYTE/UNSIGNED_BYTE/SHORT/UNSIGNED_SHORT (KHR_mesh_quantization)",
                }
            );
        }
    }
    let reader = prim.reader(|b| buffers.get(b.index()).map(|d| &d.0[..]));
    let out_of_range = |attr: &str| anyhow!("{what}: {attr} reaches past the end of its buffer");
    let with_what = |e: anyhow::Error| anyhow!("{what}: {e}");
    let positions = gltf_decode::read_vec3(&pos, buffers, "POSITION").map_err(with_what)?;
    let normals = match prim.get(&gltf::Semantic::Normals) {
        Some(n) => Some(gltf_decode::read_vec3(&n, buffers, "NORMAL").map_err(with_what)?),
        None => None,
    };
    let raw: Vec<u32> = match reader.read_indices() {
        Some(i) => i.into_u32().collect(),
        None if prim.indices().is_some() => return Err(out_of_range("indices")),
        None => (0..positions.len() as u32).collect(),
    };
    finish_primitive(mode, positions, normals, raw, what)
}

/// A Draco primitive's positions, normals and indices, held to the counts its accessors
/// declare (which bounded the scene's size before anything was read).
#[allow(clippy::type_complexity)]
fn read_draco(
    prim: &gltf::Primitive,
    d: Draco,
    buffers: &[gltf::buffer::Data],
    what: &str,
) -> Result<(Vec<Vec3>, Option<Vec<Vec3>>, Vec<u32>)> {
    let pos = prim
        .get(&gltf::Semantic::Positions)
        .ok_or_else(|| anyhow!("{what}: has no POSITION attribute"))?;
    let max_points = pos.count();
    let max_faces = prim.indices().map_or(max_points, |i| i.count()) / 3;
    let (buffer, offset, length) = d.stream;
    let stream = buffers
        .get(buffer)
        .and_then(|b| b.0.get(offset..offset.checked_add(length)?))
        .ok_or_else(|| {
            anyhow!(
                "{what}: its Draco buffer view {} reaches past the end of buffer {buffer}",
                d.view
            )
        })?;
    let m = gltf_decode::decode_draco(stream, d, max_points, max_faces)
        .map_err(|e| anyhow!("{what}: {e}"))?;
    let normals = if prim.get(&gltf::Semantic::Normals).is_some() {
        m.normals
    } else {
        None
    };
    Ok((m.positions, normals, m.indices))
}

/// Checks a primitive's vertices and indices and builds its mesh (flat normals when it
/// has none).
fn finish_primitive(
    mode: gltf::mesh::Mode,
    positions: Vec<Vec3>,
    normals: Option<Vec<Vec3>>,
    raw: Vec<u32>,
    what: &str,
) -> Result<Mesh> {
    if let Some(i) = positions.iter().position(|p| !p.is_finite()) {
        bail!(
            "{what}: vertex {i} has a non-finite coordinate ({})",
            positions[i]
        );
    }
    // Which entry, not its value: the bytes may belong to a file that is not a scene.
    if let Some(k) = raw.iter().position(|&i| i as usize >= positions.len()) {
        bail!(
            "{what}: index number {k} is out of range ({} vertices)",
            positions.len()
        );
    }
    let indices = triangle_list(mode, &raw);
    if indices.is_empty() {
        bail!("{what}: no triangles");
    }
    let mut m = Mesh {
        positions,
        normals: Vec::new(),
        indices,
    };
    match normals {
        Some(n) if n.len() == m.positions.len() => {
            m.normals = n.into_iter().map(|n| n.normalize_or_zero()).collect();
            // A zero or non-finite normal is as good as none.
            if m.normals.iter().any(|n| *n == Vec3::ZERO || !n.is_finite()) {
                m.compute_normals();
            }
        }
        Some(n) => bail!(
            "{what}: {} normals for {} positions",
            n.len(),
            m.positions.len()
        ),
        // glTF asks for flat normals when a primitive has none: one vertex per corner.
        None => m = flat(&m),
    }
    m.validate(what)?;
    Ok(m)
}

/// Checks that an accessor's elements lie inside its buffer view and the view inside its
/// buffer, with a stride no smaller than an element: the gltf crate's reader panics or
/// overflows otherwise.
fn check_range(
    a: &gltf::Accessor,
    buffers: &[gltf::buffer::Data],
    what: &str,
    attr: &str,
) -> Result<()> {
    let Some(view) = a.view() else {
        return Ok(());
    };
    let elem = a.size() as u64;
    let stride = match view.stride() {
        Some(s) if (s as u64) < elem => bail!(
            "{what}: {attr} accessor {}: its buffer view's byteStride {s} is smaller than one element ({elem} bytes)",
            a.index()
        ),
        Some(s) => s as u64,
        None => elem,
    };
    let end = (a.offset() as u64)
        .saturating_add(stride.saturating_mul(a.count() as u64 - 1))
        .saturating_add(elem);
    if end > view.length() as u64 {
        bail!(
            "{what}: {attr} accessor {} reaches past the end of its buffer view ({end} > {} bytes)",
            a.index(),
            view.length()
        );
    }
    let buffer_len = buffers.get(view.buffer().index()).map_or(0, |d| d.len()) as u64;
    if (view.offset() as u64).saturating_add(view.length() as u64) > buffer_len {
        bail!(
            "{what}: {attr}: buffer view {} reaches past the end of buffer {} ({buffer_len} bytes)",
            view.index(),
            view.buffer().index()
        );
    }
    Ok(())
}

/// Triangle-list indices for a triangles, strip or fan index sequence. Strips alternate
/// winding so every triangle keeps the first one's orientation.
fn triangle_list(mode: gltf::mesh::Mode, raw: &[u32]) -> Vec<u32> {
    use gltf::mesh::Mode;
    match mode {
        Mode::TriangleStrip => (0..raw.len().saturating_sub(2))
            .flat_map(|k| {
                if k % 2 == 0 {
                    [raw[k], raw[k + 1], raw[k + 2]]
                } else {
                    [raw[k + 1], raw[k], raw[k + 2]]
                }
            })
            .collect(),
        Mode::TriangleFan => (1..raw.len().saturating_sub(1))
            .flat_map(|k| [raw[0], raw[k], raw[k + 1]])
            .collect(),
        _ => raw[..raw.len() / 3 * 3].to_vec(),
    }
}

/// The mesh with one vertex per triangle corner and the face normal on each.
fn flat(m: &Mesh) -> Mesh {
    let mut out = Mesh::default();
    for t in m.indices.chunks_exact(3) {
        let [a, b, c] = [0, 1, 2].map(|k| m.positions[t[k] as usize]);
        let n = (b - a).cross(c - a).normalize_or(Vec3::Y);
        let base = out.positions.len() as u32;
        out.positions.extend([a, b, c]);
        out.normals.extend([n; 3]);
        out.indices.extend([base, base + 1, base + 2]);
    }
    out
}

// ---------------------------------------------------------------------------------------
// Export
// ---------------------------------------------------------------------------------------

/// Whether `path` ends in `.glb` (one file) or `.gltf` (JSON plus `FILE.bin`).
fn is_glb(path: &Path) -> Result<bool> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    match ext.as_deref() {
        Some("glb") => Ok(true),
        Some("gltf") => Ok(false),
        _ => bail!(
            "--gltf {}: a glTF export must end in .glb or .gltf",
            path.display()
        ),
    }
}

/// Checks, before any work, that `path` (and for `.gltf` its `.bin`) can be written (see
/// `crate::output::check_file`).
pub fn check_paths(path: &Path) -> Result<()> {
    if !is_glb(path)? {
        crate::output::check_file(&path.with_extension("bin"), "--gltf's buffer")?;
    }
    crate::output::check_file(path, "--gltf")
}

/// Writes `scene` as glTF to `path` (`.glb`: one file; `.gltf`: JSON plus `FILE.bin`),
/// staged and published together (`crate::output::Publish`). `width`/`height` set the
/// camera's aspect ratio.
pub fn export_gltf(scene: &Scene, path: &Path, width: u32, height: u32) -> Result<()> {
    check_paths(path)?;
    let glb = is_glb(path)?;
    let bin_path = path.with_extension("bin");
    let bin_uri = bin_path
        .file_name()
        .map(|f| f.to_string_lossy().into_owned())
        .unwrap_or_default();
    let (doc, bin) = build_document(scene, width, height, (!glb).then_some(bin_uri.as_str()));
    let json_bytes = serde_json::to_vec(&doc)?;
    let mut publish = crate::output::Publish::new();
    if glb {
        let bytes = glb_bytes(&json_bytes, &bin);
        publish.stage(path, |t| write_bytes(t, &bytes))?;
    } else {
        publish.stage(&bin_path, |t| write_bytes(t, &bin))?;
        publish.stage(path, |t| write_bytes(t, &json_bytes))?;
    }
    publish.commit()
}

fn write_bytes(path: &Path, bytes: &[u8]) -> Result<()> {
    use std::io::Write;
    let mut f = std::fs::File::create(path)?;
    f.write_all(bytes)?;
    f.sync_all()?;
    Ok(())
}

/// A GLB container: 12-byte header, a JSON chunk padded with spaces and a BIN chunk padded
/// with zeros, each to 4 bytes (glTF 2.0 spec, "Binary glTF Layout").
fn glb_bytes(json: &[u8], bin: &[u8]) -> Vec<u8> {
    let pad = |n: usize| (4 - n % 4) % 4;
    let json_len = json.len() + pad(json.len());
    let bin_len = bin.len() + pad(bin.len());
    let total = 12 + 8 + json_len + 8 + bin_len;
    let mut out = Vec::with_capacity(total);
    out.extend_from_slice(b"glTF");
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&(total as u32).to_le_bytes());
    out.extend_from_slice(&(json_len as u32).to_le_bytes());
    out.extend_from_slice(b"JSON");
    out.extend_from_slice(json);
    out.extend(std::iter::repeat_n(b' ', pad(json.len())));
    out.extend_from_slice(&(bin_len as u32).to_le_bytes());
    out.extend_from_slice(b"BIN\0");
    out.extend_from_slice(bin);
    out.extend(std::iter::repeat_n(0u8, pad(bin.len())));
    out
}

fn role_name(r: Role) -> &'static str {
    match r {
        Role::Caster => "caster",
        Role::Receiver => "receiver",
        Role::Both => "both",
    }
}

/// The rotation that turns a node's -Z towards `forward` with its +Y towards `up` (the
/// glTF convention for cameras and spot lights).
fn look_rotation(forward: Vec3, up: Vec3) -> Quat {
    let f = forward.normalize();
    let up = if up.cross(f).length_squared() > 1e-12 {
        up
    } else {
        f.any_orthonormal_vector()
    };
    let right = f.cross(up).normalize();
    let true_up = right.cross(f);
    Quat::from_mat3(&Mat3::from_cols(right, true_up, -f)).normalize()
}

/// The glTF JSON and its binary buffer. `bin_uri` names an external buffer (`.gltf`);
/// `None` leaves the buffer as the GLB blob.
fn build_document(
    scene: &Scene,
    width: u32,
    height: u32,
    bin_uri: Option<&str>,
) -> (Value, Vec<u8>) {
    let mut bin: Vec<u8> = Vec::new();
    let mut views: Vec<Value> = Vec::new();
    let mut accessors: Vec<Value> = Vec::new();
    let mut push_view = |bin: &mut Vec<u8>, bytes: &[u8], target: u32| -> usize {
        while !bin.len().is_multiple_of(4) {
            bin.push(0);
        }
        views.push(json!({
            "buffer": 0, "byteOffset": bin.len(), "byteLength": bytes.len(), "target": target
        }));
        bin.extend_from_slice(bytes);
        views.len() - 1
    };
    const ARRAY_BUFFER: u32 = 34962;
    const ELEMENT_ARRAY_BUFFER: u32 = 34963;
    const FLOAT: u32 = 5126;
    const UNSIGNED_INT: u32 = 5125;

    // Accessors once per distinct mesh; a glTF mesh per (mesh, albedo), since the
    // material belongs to the primitive.
    let mut mesh_accessors: HashMap<*const Mesh, (usize, usize, usize)> = HashMap::new();
    let mut materials: Vec<Value> = Vec::new();
    let mut material_of: HashMap<[u32; 3], usize> = HashMap::new();
    let mut meshes: Vec<Value> = Vec::new();
    let mut mesh_of: HashMap<(*const Mesh, usize), usize> = HashMap::new();
    let mut nodes: Vec<Value> = Vec::new();
    for o in &scene.objects {
        let key = Arc::as_ptr(&o.mesh);
        let (pa, na, ia) = *mesh_accessors.entry(key).or_insert_with(|| {
            let m = &o.mesh;
            let b = m.bounds();
            let pv = push_view(&mut bin, bytemuck::cast_slice(&m.positions), ARRAY_BUFFER);
            accessors.push(json!({
                "bufferView": pv, "componentType": FLOAT, "count": m.positions.len(),
                "type": "VEC3", "min": b.min.to_array(), "max": b.max.to_array()
            }));
            let nv = push_view(&mut bin, bytemuck::cast_slice(&m.normals), ARRAY_BUFFER);
            accessors.push(json!({
                "bufferView": nv, "componentType": FLOAT, "count": m.normals.len(), "type": "VEC3"
            }));
            let iv = push_view(
                &mut bin,
                bytemuck::cast_slice(&m.indices),
                ELEMENT_ARRAY_BUFFER,
            );
            accessors.push(json!({
                "bufferView": iv, "componentType": UNSIGNED_INT, "count": m.indices.len(),
                "type": "SCALAR"
            }));
            let n = accessors.len();
            (n - 3, n - 2, n - 1)
        });
        let albedo_key = o.albedo.to_array().map(f32::to_bits);
        let material = *material_of.entry(albedo_key).or_insert_with(|| {
            materials.push(json!({
                "pbrMetallicRoughness": {
                    "baseColorFactor": [o.albedo.x, o.albedo.y, o.albedo.z, 1.0],
                    "metallicFactor": 0.0,
                    "roughnessFactor": 1.0
                }
            }));
            materials.len() - 1
        });
        let mesh = *mesh_of.entry((key, material)).or_insert_with(|| {
            meshes.push(json!({
                "name": o.name,
                "primitives": [{
                    "attributes": { "POSITION": pa, "NORMAL": na },
                    "indices": ia,
                    "material": material,
                    "mode": 4
                }]
            }));
            meshes.len() - 1
        });
        nodes.push(json!({
            "name": o.name,
            "mesh": mesh,
            "matrix": o.transform.to_cols_array(),
            "extras": { EXTRAS_KEY: { "role": role_name(o.role) } }
        }));
    }

    let l = &scene.light;
    let ldir = (l.target - l.position).normalize_or(Vec3::NEG_Y);
    let lrot = look_rotation(ldir, Vec3::Y);
    nodes.push(json!({
        "name": "light",
        "translation": l.position.to_array(),
        "rotation": lrot.to_array(),
        "extensions": { "KHR_lights_punctual": { "light": 0 } }
    }));
    let c = &scene.camera;
    let crot = look_rotation(c.target - c.position, c.up);
    let size = scene.bounds().radius().max(1e-3);
    nodes.push(json!({
        "name": "camera",
        "translation": c.position.to_array(),
        "rotation": crot.to_array(),
        "camera": 0
    }));
    let mut buffer = json!({ "byteLength": bin.len() });
    if let Some(uri) = bin_uri {
        buffer["uri"] = json!(uri);
    }
    let doc = json!({
        "asset": {
            "version": "2.0",
            "generator": concat!("softshadow ", env!("CARGO_PKG_VERSION"))
        },
        "extensionsUsed": ["KHR_lights_punctual"],
        "extensions": {
            "KHR_lights_punctual": {
                "lights": [light_json(l)]
            }
        },
        "scene": 0,
        "scenes": [{ "name": scene.name, "nodes": (0..nodes.len()).collect::<Vec<_>>() }],
        "nodes": nodes,
        "meshes": meshes,
        "materials": materials,
        "cameras": [{
            "type": "perspective",
            "perspective": {
                "yfov": c.fov_deg.to_radians(),
                "aspectRatio": width as f32 / height.max(1) as f32,
                "znear": size * 1e-3
            }
        }],
        "accessors": accessors,
        "bufferViews": views,
        "buffers": [buffer]
    });
    (doc, bin)
}

/// The KHR_lights_punctual light of `l`: a spot with its radius in extras, or a directional
/// light (shining along its node's -Z) with its angular radius in extras.
fn light_json(l: &Light) -> Value {
    match l.sun_angle_deg() {
        Some(a) => json!({
            "name": "light",
            "type": "directional",
            "color": [1.0, 1.0, 1.0],
            "intensity": 1.0,
            "extras": { EXTRAS_KEY: { "angular_radius_deg": a } }
        }),
        None => json!({
            "name": "light",
            "type": "spot",
            "color": [1.0, 1.0, 1.0],
            "intensity": 1.0,
            "spot": {
                "innerConeAngle": 0.0,
                "outerConeAngle": (l.fov_deg * 0.5).to_radians()
            },
            "extras": { EXTRAS_KEY: { "radius": l.radius } }
        }),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use gltf::mesh::Mode;

    #[test]
    fn strips_and_fans_become_lists_with_one_winding() {
        assert_eq!(
            triangle_list(Mode::TriangleStrip, &[0, 1, 2, 3]),
            vec![0, 1, 2, 2, 1, 3]
        );
        assert_eq!(
            triangle_list(Mode::TriangleFan, &[0, 1, 2, 3]),
            vec![0, 1, 2, 0, 2, 3]
        );
        assert!(triangle_list(Mode::TriangleStrip, &[0, 1]).is_empty());
    }

    #[test]
    fn look_rotation_points_minus_z_along_forward() {
        let f = Vec3::new(0.3, -0.8, 0.2).normalize();
        let q = look_rotation(f, Vec3::Y);
        assert!((q * Vec3::NEG_Z - f).length() < 1e-6);
        assert!((q * Vec3::Y).dot(Vec3::Y) > 0.0, "up stays up");
        // Straight down: any roll, still -Z along forward.
        let q = look_rotation(Vec3::NEG_Y, Vec3::Y);
        assert!((q * Vec3::NEG_Z - Vec3::NEG_Y).length() < 1e-6);
    }

    #[test]
    fn validation_findings_are_cut_to_a_few() {
        assert_eq!(few("a: x; b: y;"), "a: x; b: y");
        let many: String = (0..2000)
            .map(|k| format!("m[{k}]: Missing data; "))
            .collect();
        let line = few(&many);
        assert!(line.ends_with("; and 1997 more"), "{line}");
        assert!(line.starts_with("m[0]: Missing data; m[1]"), "{line}");
    }

    #[test]
    fn json_depth_skips_strings() {
        assert_eq!(json_depth(br#"{"a": [[1], "[[[[\"[["], {}]}"#), 3);
        assert_eq!(json_depth(b"[]"), 1);
        assert_eq!(json_depth(b"1"), 0);
    }

    #[test]
    fn glb_chunks_are_padded_and_sized() {
        let b = glb_bytes(b"{}", &[1, 2, 3, 4, 5]);
        assert_eq!(&b[0..4], b"glTF");
        assert_eq!(b.len() % 4, 0);
        assert_eq!(
            u32::from_le_bytes(b[8..12].try_into().unwrap()) as usize,
            b.len()
        );
        assert_eq!(&b[16..20], b"JSON");
        assert_eq!(&b[20..24], b"{}  ");
    }
}
