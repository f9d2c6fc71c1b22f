//! TOML scene files (format documented in docs/SCENES.md): `[[object]]` tables with a
//! mesh path or a primitive and a transform, an optional `[light]` and `[camera]` whose
//! missing fields are fitted to the casters as for the built-in scenes.
//!
//! Unknown keys are errors that name the key (serde `deny_unknown_fields`); numbers are
//! checked (finite, fov in (0, 180), radius >= 0, scale != 0) before anything is built.

use super::input::{self, LoadOptions};
use super::{builtin, obj, primitives as prim, Camera, Light, Mesh, Object, Role, Scene};
use anyhow::{bail, Context, Result};
use glam::{Mat4, Vec2, Vec3};
use serde::Deserialize;
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SceneFile {
    /// Defaults to the file stem.
    pub name: Option<String>,
    #[serde(default, rename = "object")]
    pub objects: Vec<ObjectSpec>,
    pub light: Option<LightSpec>,
    pub camera: Option<CameraSpec>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ObjectSpec {
    pub name: Option<String>,
    /// OBJ path, relative to the scene file.
    pub mesh: Option<String>,
    /// "plane" | "box" | "cylinder" | "sphere" | "torus".
    pub primitive: Option<String>,
    // Primitive parameters; each primitive takes only its own (checked in `build_mesh`).
    pub size: Option<Size>,
    pub radius: Option<f32>,
    pub height: Option<f32>,
    pub segments: Option<u32>,
    pub rings: Option<u32>,
    pub major_radius: Option<f32>,
    pub minor_radius: Option<f32>,
    pub minor_segments: Option<u32>,
    pub translate: Option<[f32; 3]>,
    /// Degrees about the world X axis, then Y, then Z.
    pub rotate_deg: Option<[f32; 3]>,
    pub scale: Option<Size>,
    pub role: Option<Role>,
    pub albedo: Option<[f32; 3]>,
}

/// A scalar (uniform) or per-axis size / scale.
#[derive(Debug, Clone, Copy, Deserialize)]
#[serde(untagged)]
pub enum Size {
    Uniform(f32),
    Vec2([f32; 2]),
    Vec3([f32; 3]),
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LightSpec {
    /// "spot" (the default) or "sun".
    pub kind: Option<String>,
    pub position: Option<[f32; 3]>,
    pub target: Option<[f32; 3]>,
    pub fov_deg: Option<f32>,
    pub radius: Option<f32>,
    /// A sun's direction towards the light.
    pub direction: Option<[f32; 3]>,
    /// A sun's angular radius.
    pub angular_radius_deg: Option<f32>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CameraSpec {
    pub position: Option<[f32; 3]>,
    pub target: Option<[f32; 3]>,
    pub up: Option<[f32; 3]>,
    pub fov_deg: Option<f32>,
}

/// How far along its direction a sun's `Light::position` sits, in scene sizes: only a point
/// for exports and the default camera's framing (a sun has no position).
const SUN_RIG_DISTANCE: f32 = 4.0;

/// Loads and builds a scene file; OBJ meshes are resolved against the file's folder and,
/// unless `opts` allows otherwise, must lie inside it.
pub fn load_toml(path: &Path, opts: &LoadOptions) -> Result<Scene> {
    let name = input::shown_path(path);
    let bytes = input::read_file(path, &name)?;
    let text = String::from_utf8(bytes).map_err(|e| {
        anyhow::anyhow!(
            "{name}: not a text scene file (invalid UTF-8 at byte {})",
            e.utf8_error().valid_up_to()
        )
    })?;
    let stem = path
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "scene".into());
    let dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
    parse_toml_with(&text, &name, &stem, &dir, opts)
}

/// Parses scene TOML text. `file` labels errors, `stem` is the default scene name and
/// `dir` the folder that relative mesh paths start from (and stay inside).
pub fn parse_toml(text: &str, file: &str, stem: &str, dir: &Path) -> Result<Scene> {
    parse_toml_with(text, file, stem, dir, &LoadOptions::default())
}

/// [`parse_toml`] with the options of [`LoadOptions`].
pub fn parse_toml_with(
    text: &str,
    file: &str,
    stem: &str,
    dir: &Path,
    opts: &LoadOptions,
) -> Result<Scene> {
    let spec: SceneFile = toml::from_str(text).map_err(|e| {
        // toml's own Display spans several lines with a source excerpt; keep one line, and
        // of what it quotes from the file only short printable tokens.
        let at = e
            .span()
            .map(|s| {
                let line = text[..s.start.min(text.len())].matches('\n').count() + 1;
                format!(" line {line}:")
            })
            .unwrap_or_default();
        anyhow::anyhow!("{file}:{at} {}", clip_words(e.message().trim()))
    })?;
    build(spec, file, stem, dir, opts)
}

/// A parser's message with each word escaped and clipped, so that a value pasted from
/// another file cannot be echoed whole.
fn clip_words(message: &str) -> String {
    message
        .split_whitespace()
        .map(|w| input::token(w, 40))
        .collect::<Vec<_>>()
        .join(" ")
}

/// An upper bound on the triangles of a primitive, known before it is built (clamped
/// parameters are checked again when it is).
fn primitive_triangles(o: &ObjectSpec, kind: &str) -> usize {
    let n = |v: Option<u32>, default: u32| v.unwrap_or(default).min(4096) as usize;
    match kind {
        "plane" => 2 * n(o.segments, 8).pow(2),
        "box" => 12,
        "cylinder" => 4 * n(o.segments, 32),
        "sphere" => 2 * n(o.segments, 32) * (n(o.rings, 16) + 1),
        "torus" => 2 * n(o.segments, 48) * n(o.minor_segments, 16),
        _ => 0,
    }
}

fn finite(file: &str, what: &str, v: &[f32]) -> Result<()> {
    if v.iter().any(|x| !x.is_finite()) {
        bail!("{file}: {what} {v:?} must be finite");
    }
    Ok(())
}

fn vec3(file: &str, what: &str, v: [f32; 3]) -> Result<Vec3> {
    finite(file, what, &v)?;
    Ok(Vec3::from(v))
}

fn fov(file: &str, what: &str, f: f32) -> Result<f32> {
    if !(f > 0.0 && f < 180.0) {
        bail!("{file}: {what} {f} must be in (0, 180)");
    }
    Ok(f)
}

fn build(spec: SceneFile, file: &str, stem: &str, dir: &Path, opts: &LoadOptions) -> Result<Scene> {
    if spec.objects.is_empty() {
        bail!("{file}: no [[object]] tables");
    }
    // One mesh per distinct OBJ path, shared by every object that names it.
    let mut loaded: HashMap<PathBuf, Arc<Mesh>> = HashMap::new();
    let mut objects = Vec::with_capacity(spec.objects.len());
    // Every instance counts: each is drawn and ray cast on its own.
    let mut triangles = 0usize;
    let over = |label: &str, triangles: usize| {
        anyhow::anyhow!(
            "{label}: brings the scene to {triangles} triangles, above the limit of {} per scene",
            input::MAX_SCENE_TRIANGLES
        )
    };
    for (k, o) in spec.objects.iter().enumerate() {
        let label = match &o.name {
            Some(n) => format!("{file}: object {} ('{}')", k + 1, input::shown(n)),
            None => format!("{file}: object {}", k + 1),
        };
        if let Some(p) = &o.primitive {
            let t = triangles.saturating_add(primitive_triangles(o, p));
            if t > input::MAX_SCENE_TRIANGLES {
                return Err(over(&label, t));
            }
        }
        let (mesh, default_name) = match (&o.mesh, &o.primitive) {
            (Some(_), Some(_)) => bail!("{label}: give either 'mesh' or 'primitive', not both"),
            (None, None) => bail!("{label}: needs 'mesh = \"file.obj\"' or 'primitive = \"box\"'"),
            (Some(m), None) => {
                if let Some(p) = first_param(o) {
                    bail!("{label}: parameter '{p}' applies to primitives, not to a mesh");
                }
                let p = input::resolve_inside(dir, Path::new(m), opts, &format!("{label}: mesh"))?;
                let mesh = match loaded.get(&p) {
                    Some(mesh) => mesh.clone(),
                    None => {
                        let mesh = Arc::new(obj::load_obj(&p)?);
                        loaded.insert(p.clone(), mesh.clone());
                        mesh
                    }
                };
                let n = p.file_stem().map(|s| s.to_string_lossy().into_owned());
                (mesh, n.unwrap_or_else(|| "mesh".into()))
            }
            (None, Some(p)) => (Arc::new(build_primitive(o, p, &label)?), p.clone()),
        };
        triangles = triangles.saturating_add(mesh.triangle_count());
        if triangles > input::MAX_SCENE_TRIANGLES {
            return Err(over(&label, triangles));
        }
        let t = vec3(&label, "translate", o.translate.unwrap_or([0.0; 3]))?;
        let r = vec3(&label, "rotate_deg", o.rotate_deg.unwrap_or([0.0; 3]))?;
        let s = match o.scale.unwrap_or(Size::Uniform(1.0)) {
            Size::Uniform(s) => Vec3::splat(s),
            Size::Vec3(v) => Vec3::from(v),
            Size::Vec2(_) => bail!("{label}: scale must be a number or [x, y, z]"),
        };
        finite(&label, "scale", &s.to_array())?;
        if s.cmpeq(Vec3::ZERO).any() {
            bail!("{label}: scale {s} has a zero component");
        }
        let albedo = vec3(&label, "albedo", o.albedo.unwrap_or([0.8; 3]))?;
        if albedo.min_element() < 0.0 {
            bail!("{label}: albedo {albedo} must be >= 0");
        }
        let rot = Mat4::from_rotation_z(r.z.to_radians())
            * Mat4::from_rotation_y(r.y.to_radians())
            * Mat4::from_rotation_x(r.x.to_radians());
        let transform = Mat4::from_translation(t) * rot * Mat4::from_scale(s);
        let role = o.role.unwrap_or(Role::Both);
        let name = o
            .name
            .clone()
            .unwrap_or_else(|| format!("{default_name}{}", k + 1));
        objects.push(Object::new(name, mesh, transform, role, albedo));
    }

    // Defaults come from the same fitting as the built-in scenes, so a file may give as
    // little as a light position.
    let bounds = objects
        .iter()
        .fold(super::Aabb::EMPTY, |b, o| b.union(o.world_bounds()));
    let ground_y = if bounds.is_empty() { 0.0 } else { bounds.min.y };
    let size = bounds.extent().max_element().max(1e-3);
    let default_light = bounds.center() + Vec3::new(-1.2, 2.5, 0.8) * size;
    let ls = spec.light.unwrap_or(LightSpec {
        kind: None,
        position: None,
        target: None,
        fov_deg: None,
        radius: None,
        direction: None,
        angular_radius_deg: None,
    });
    let sun = match ls.kind.as_deref() {
        None | Some("spot") => false,
        Some("sun") => true,
        Some(k) => bail!(
            "{file}: light kind '{}' is unknown: expected \"spot\" or \"sun\"",
            input::shown(k)
        ),
    };
    for (key, set) in [
        ("direction", ls.direction.is_some()),
        ("angular_radius_deg", ls.angular_radius_deg.is_some()),
    ] {
        if set && !sun {
            bail!("{file}: light {key} applies only to a sun (kind = \"sun\"); a spotlight takes position, target, fov_deg and radius");
        }
    }
    let sun_dir = match ls.direction {
        Some(d) => {
            let d = vec3(file, "light direction", d)?;
            if d.length_squared() <= 1e-12 {
                bail!("{file}: light direction {d} has no length: it must point towards the sun");
            }
            d.normalize()
        }
        None => (default_light - bounds.center()).normalize(),
    };
    let lpos = match ls.position {
        Some(p) => vec3(file, "light position", p)?,
        // A sun's shadows are parallel: the rig's camera frames them as a distant light's.
        None if sun => bounds.center() + sun_dir * (SUN_RIG_DISTANCE * size),
        None => default_light,
    };
    let (auto_light, auto_cam) =
        builtin::rig(&objects, lpos, ground_y, 0.04, Vec3::new(0.4, 0.6, 1.0));
    let light = if sun {
        for (key, set) in [
            ("position", ls.position.is_some()),
            ("fov_deg", ls.fov_deg.is_some()),
            ("radius", ls.radius.is_some()),
        ] {
            if set {
                bail!("{file}: light {key} does not apply to a sun (kind = \"sun\"): a sun takes direction (towards the light), angular_radius_deg and target");
            }
        }
        let target = match ls.target {
            Some(t) => vec3(file, "light target", t)?,
            None => bounds.center(),
        };
        let angle = match ls.angular_radius_deg {
            Some(a) if !(0.0..=super::MAX_SUN_ANGLE_DEG).contains(&a) => bail!(
                "{file}: light angular_radius_deg {a} is out of range: allowed 0 ..= {} degrees",
                super::MAX_SUN_ANGLE_DEG
            ),
            Some(a) => a,
            None => super::DEFAULT_SUN_ANGLE_DEG,
        };
        Light::sun(sun_dir, target, angle, SUN_RIG_DISTANCE * size)
    } else {
        Light {
            position: lpos,
            target: match ls.target {
                Some(t) => vec3(file, "light target", t)?,
                None => auto_light.target,
            },
            fov_deg: match ls.fov_deg {
                Some(f) => fov(file, "light fov_deg", f)?,
                None => auto_light.fov_deg,
            },
            radius: match ls.radius {
                Some(r) if !r.is_finite() || r < 0.0 => {
                    bail!("{file}: light radius {r} must be finite and >= 0")
                }
                Some(r) => r,
                None => auto_light.radius,
            },
            kind: super::LightKind::Spot,
        }
    };
    let cs = spec.camera.unwrap_or(CameraSpec {
        position: None,
        target: None,
        up: None,
        fov_deg: None,
    });
    let camera = Camera {
        position: match cs.position {
            Some(p) => vec3(file, "camera position", p)?,
            None => auto_cam.position,
        },
        target: match cs.target {
            Some(t) => vec3(file, "camera target", t)?,
            None => auto_cam.target,
        },
        up: match cs.up {
            Some(u) => vec3(file, "camera up", u)?,
            None => Vec3::Y,
        },
        fov_deg: match cs.fov_deg {
            Some(f) => fov(file, "camera fov_deg", f)?,
            None => auto_cam.fov_deg,
        },
    };
    let scene = Scene {
        name: spec.name.unwrap_or_else(|| stem.into()),
        objects,
        light,
        camera,
    };
    scene
        .validate()
        .with_context(|| format!("{file}: invalid scene"))?;
    Ok(scene)
}

/// The first primitive parameter set on `o`, for "does not apply" errors.
fn first_param(o: &ObjectSpec) -> Option<&'static str> {
    [
        ("size", o.size.is_some()),
        ("radius", o.radius.is_some()),
        ("height", o.height.is_some()),
        ("segments", o.segments.is_some()),
        ("rings", o.rings.is_some()),
        ("major_radius", o.major_radius.is_some()),
        ("minor_radius", o.minor_radius.is_some()),
        ("minor_segments", o.minor_segments.is_some()),
    ]
    .into_iter()
    .find(|(_, set)| *set)
    .map(|(n, _)| n)
}

fn build_primitive(o: &ObjectSpec, kind: &str, label: &str) -> Result<Mesh> {
    let allowed: &[&str] = match kind {
        "plane" => &["size", "segments"],
        "box" => &["size"],
        "cylinder" => &["radius", "height", "segments"],
        "sphere" => &["radius", "segments", "rings"],
        "torus" => &["major_radius", "minor_radius", "segments", "minor_segments"],
        _ => bail!(
            "{label}: unknown primitive '{kind}' (expected plane, box, cylinder, sphere or torus)"
        ),
    };
    let set = [
        ("size", o.size.is_some()),
        ("radius", o.radius.is_some()),
        ("height", o.height.is_some()),
        ("segments", o.segments.is_some()),
        ("rings", o.rings.is_some()),
        ("major_radius", o.major_radius.is_some()),
        ("minor_radius", o.minor_radius.is_some()),
        ("minor_segments", o.minor_segments.is_some()),
    ];
    if let Some((p, _)) = set.iter().find(|(p, s)| *s && !allowed.contains(p)) {
        bail!(
            "{label}: parameter '{p}' does not apply to a {kind} (it takes {})",
            allowed.join(", ")
        );
    }
    let positive = |what: &str, v: Option<f32>, default: f32| -> Result<f32> {
        let v = v.unwrap_or(default);
        if !v.is_finite() || v <= 0.0 {
            bail!("{label}: {what} {v} must be finite and > 0");
        }
        Ok(v)
    };
    // Cap tessellation so a typo cannot ask for billions of triangles.
    let count = |what: &str, v: Option<u32>, default: u32, min: u32| -> Result<u32> {
        let v = v.unwrap_or(default);
        if !(min..=4096).contains(&v) {
            bail!("{label}: {what} {v} must be in {min}..=4096");
        }
        Ok(v)
    };
    let size3 = |default: Vec3| -> Result<Vec3> {
        let s = match o.size {
            None => default,
            Some(Size::Uniform(s)) => Vec3::splat(s),
            Some(Size::Vec3(v)) => Vec3::from(v),
            Some(Size::Vec2(_)) => bail!("{label}: box size must be a number or [x, y, z]"),
        };
        if !s.is_finite() || s.min_element() <= 0.0 {
            bail!("{label}: size {s} must be finite and > 0");
        }
        Ok(s)
    };
    Ok(match kind {
        "plane" => {
            let s = match o.size {
                None => Vec2::splat(10.0),
                Some(Size::Uniform(s)) => Vec2::splat(s),
                Some(Size::Vec2(v)) => Vec2::from(v),
                Some(Size::Vec3(_)) => bail!("{label}: plane size must be a number or [x, z]"),
            };
            if !s.is_finite() || s.min_element() <= 0.0 {
                bail!("{label}: size {s} must be finite and > 0");
            }
            prim::plane(s, count("segments", o.segments, 8, 1)?)
        }
        "box" => prim::cuboid(size3(Vec3::ONE)?),
        "cylinder" => prim::cylinder(
            positive("radius", o.radius, 0.5)?,
            positive("height", o.height, 1.0)?,
            count("segments", o.segments, 32, 3)?,
        ),
        "sphere" => prim::sphere(
            positive("radius", o.radius, 0.5)?,
            count("segments", o.segments, 32, 3)?,
            count("rings", o.rings, 16, 2)?,
        ),
        _ => prim::torus(
            positive("major_radius", o.major_radius, 1.0)?,
            positive("minor_radius", o.minor_radius, 0.25)?,
            count("segments", o.segments, 48, 3)?,
            count("minor_segments", o.minor_segments, 16, 3)?,
        ),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> Result<Scene> {
        parse_toml(text, "t.toml", "t", Path::new("."))
    }

    #[test]
    fn minimal_file_gets_a_fitted_light_and_camera() {
        let s = parse(
            "[[object]]\nprimitive = \"plane\"\nrole = \"receiver\"\n\
             [[object]]\nprimitive = \"sphere\"\nradius = 1\ntranslate = [0, 2, 0]\n",
        )
        .unwrap();
        assert_eq!(s.objects.len(), 2);
        assert_eq!(s.name, "t");
        // The sphere (radius 1 at y = 2) is the only caster: the fitted light is above it,
        // aimed between it and its shadow on the ground, with a cone that holds the sphere,
        // and a radius a few percent of the region it lights.
        let sphere = Vec3::new(0.0, 2.0, 0.0);
        let l = s.light;
        assert!(l.position.y > 3.0, "light at {}", l.position);
        assert!(
            l.target.y >= -1e-3 && l.target.y <= 3.0,
            "light target {}",
            l.target
        );
        let axis = (l.target - l.position).normalize();
        let to_sphere = sphere - l.position;
        let half_angle = to_sphere.normalize().angle_between(axis).to_degrees()
            + (1.0 / to_sphere.length()).asin().to_degrees();
        assert!(
            half_angle <= l.fov_deg * 0.5 && l.fov_deg < 120.0,
            "the sphere spans {half_angle} degrees off the axis of a {} degree cone",
            l.fov_deg
        );
        assert!(
            l.radius > 0.04 && l.radius < 1.0,
            "radius {} for a 2-unit caster",
            l.radius
        );
        // The camera looks at the same region from above, the sphere inside its 45 degrees.
        let c = s.camera;
        assert_eq!(c.fov_deg, 45.0);
        assert!(c.position.y > c.target.y, "camera {c:?}");
        let view = (c.target - c.position).normalize();
        assert!(
            (sphere - c.position)
                .normalize()
                .angle_between(view)
                .to_degrees()
                < 22.5,
            "the sphere is outside the camera's view: {c:?}"
        );
        assert!((c.target - l.target).length() < 1e-3, "{c:?} {l:?}");
    }

    #[test]
    fn errors_name_the_problem() {
        let e = format!(
            "{:#}",
            parse("[[object]]\nprimitive = \"box\"\ncolour = [1, 0, 0]\n").unwrap_err()
        );
        assert!(
            e.contains("colour") && e.contains("t.toml") && !e.contains('\n'),
            "{e}"
        );
        let e = format!(
            "{:#}",
            parse("[[object]]\nprimitive = \"box\"\nradius = 1\n").unwrap_err()
        );
        assert!(e.contains("'radius'") && e.contains("box"), "{e}");
        let e = format!(
            "{:#}",
            parse("[[object]]\nprimitive = \"cone\"\n").unwrap_err()
        );
        assert!(e.contains("cone"), "{e}");
        let e = format!(
            "{:#}",
            parse("[[object]]\nprimitive = \"box\"\nscale = 0\n").unwrap_err()
        );
        assert!(e.contains("scale"), "{e}");
        let e = format!("{:#}", parse("[[object]]\nprimitive = \"box\"\nrole=\"both\"\n[[object]]\nprimitive=\"plane\"\nrole=\"receiver\"\n[light]\nfov_deg = 180\n").unwrap_err());
        assert!(e.contains("fov_deg"), "{e}");
        let e = format!(
            "{:#}",
            parse("[[object]]\nprimitive = \"box\"\n[light]\nradius = -1\n").unwrap_err()
        );
        assert!(e.contains("radius"), "{e}");
        let e = format!(
            "{:#}",
            parse("[[object]]\nprimitive = \"box\"\ntranslate = [0, nan, 0]\n").unwrap_err()
        );
        assert!(e.contains("translate") && e.contains("finite"), "{e}");
        let e = format!(
            "{:#}",
            parse("[[object]]\nmesh = \"missing.obj\"\n").unwrap_err()
        );
        assert!(e.contains("missing.obj"), "{e}");
        let e = format!(
            "{:#}",
            parse("[[object]]\nprimitive = \"box\"\nrole = \"receiver\"\n").unwrap_err()
        );
        assert!(e.contains("casts"), "{e}");
    }
}
