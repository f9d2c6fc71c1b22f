//! `softshadow export`: the scene as outside tools see it. `FILE.obj` holds every triangle
//! in world space (after transforms and tessellation), one `o NAME` group per object, with
//! world normals; `FILE.json` beside it holds the lights and the camera (docs/DESIGN.md).
//!
//! Both files are staged under temporary names in the same folder and published together
//! (`crate::output::Publish`), so a failure never leaves one without the other or half a file.

use super::{normal_matrix, Scene};
use anyhow::Result;
use serde::Serialize;
use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

/// `kind` "spot": `position`, `target`, `fov_deg`, `radius`. `kind` "sun": `direction`
/// (unit, towards the light), `angular_radius_deg`, and `position`/`target` a point on its
/// axis and the point it is aimed at; `fov_deg` and `radius` are left out.
#[derive(Serialize)]
struct LightJson {
    kind: &'static str,
    position: [f32; 3],
    target: [f32; 3],
    #[serde(skip_serializing_if = "Option::is_none")]
    fov_deg: Option<f32>,
    #[serde(skip_serializing_if = "Option::is_none")]
    radius: Option<f32>,
    #[serde(skip_serializing_if = "Option::is_none")]
    direction: Option<[f32; 3]>,
    #[serde(skip_serializing_if = "Option::is_none")]
    angular_radius_deg: Option<f32>,
}

#[derive(Serialize)]
struct CameraJson {
    position: [f32; 3],
    target: [f32; 3],
    up: [f32; 3],
    /// Vertical field of view.
    fov_deg: f32,
    width: u32,
    height: u32,
}

#[derive(Serialize)]
struct ObjectJson {
    name: String,
    role: super::Role,
    albedo: [f32; 3],
    triangles: usize,
}

#[derive(Serialize)]
struct SceneJson {
    scene: String,
    obj: String,
    up_axis: &'static str,
    triangles: usize,
    lights: Vec<LightJson>,
    camera: CameraJson,
    objects: Vec<ObjectJson>,
}

/// `FILE.json` beside `FILE.obj`.
pub fn json_path(obj_path: &Path) -> PathBuf {
    obj_path.with_extension("json")
}

/// Writes `obj_path` and its `.json` sidecar (see the module docs). `width` and `height`
/// are the camera's image size, recorded so an outside tool can rebuild its rays.
pub fn export_obj(scene: &Scene, obj_path: &Path, width: u32, height: u32) -> Result<()> {
    let json_final = json_path(obj_path);
    check_paths(obj_path)?;
    let mut publish = crate::output::Publish::new();
    publish.stage(obj_path, |t| write_obj(scene, t))?;
    publish.stage(&json_final, |t| {
        write_json(scene, obj_path, t, width, height)
    })?;
    publish.commit()
}

/// Checks, before any work, that `obj_path` and its `.json` can be written (see
/// `crate::output::check_file`).
pub fn check_paths(obj_path: &Path) -> Result<()> {
    if json_path(obj_path) == obj_path {
        anyhow::bail!(
            "--obj {}: the JSON sidecar would overwrite it; name the file .obj",
            obj_path.display()
        );
    }
    crate::output::check_file(obj_path, "--obj")?;
    crate::output::check_file(&json_path(obj_path), "--obj's JSON")
}

fn write_obj(scene: &Scene, path: &Path) -> Result<()> {
    let mut w = BufWriter::new(File::create(path)?);
    writeln!(
        w,
        "# softshadow export of scene '{}': world space, Y up",
        scene.name
    )?;
    writeln!(
        w,
        "# {} triangles, {} objects",
        scene.triangle_count(),
        scene.objects.len()
    )?;
    let mut base = 1usize;
    for o in &scene.objects {
        // OBJ object names end at whitespace.
        let name: String = o
            .name
            .chars()
            .map(|c| if c.is_whitespace() { '_' } else { c })
            .collect();
        writeln!(w, "o {name}")?;
        let m = &o.mesh;
        let nm = normal_matrix(o.transform);
        for p in &m.positions {
            let p = o.transform.transform_point3(*p);
            writeln!(w, "v {} {} {}", p.x, p.y, p.z)?;
        }
        for n in &m.normals {
            let n = (nm * *n).normalize_or(glam::Vec3::Y);
            writeln!(w, "vn {} {} {}", n.x, n.y, n.z)?;
        }
        // A mirroring transform flips the winding; swap two corners to keep faces outward.
        let flip = o.transform.determinant() < 0.0;
        for t in m.indices.chunks_exact(3) {
            let [a, b, c] = [t[0], t[1], t[2]].map(|i| i as usize + base);
            let (b, c) = if flip { (c, b) } else { (b, c) };
            writeln!(w, "f {a}//{a} {b}//{b} {c}//{c}")?;
        }
        base += m.positions.len();
    }
    let file = w.into_inner().map_err(|e| e.into_error())?;
    file.sync_all()?;
    Ok(())
}

fn write_json(scene: &Scene, obj_path: &Path, path: &Path, width: u32, height: u32) -> Result<()> {
    let l = &scene.light;
    let c = &scene.camera;
    let doc = SceneJson {
        scene: scene.name.clone(),
        obj: obj_path
            .file_name()
            .map(|f| f.to_string_lossy().into_owned())
            .unwrap_or_default(),
        up_axis: "y",
        triangles: scene.triangle_count(),
        lights: vec![LightJson {
            kind: l.kind_name(),
            position: l.position.to_array(),
            target: l.target.to_array(),
            fov_deg: (!l.is_sun()).then_some(l.fov_deg),
            radius: (!l.is_sun()).then_some(l.radius),
            direction: l.is_sun().then(|| l.direction().to_array()),
            angular_radius_deg: l.sun_angle_deg(),
        }],
        camera: CameraJson {
            position: c.position.to_array(),
            target: c.target.to_array(),
            up: c.up.to_array(),
            fov_deg: c.fov_deg,
            width,
            height,
        },
        objects: scene
            .objects
            .iter()
            .map(|o| ObjectJson {
                name: o.name.clone(),
                role: o.role,
                albedo: o.albedo.to_array(),
                triangles: o.mesh.triangle_count(),
            })
            .collect(),
    };
    let mut w = BufWriter::new(File::create(path)?);
    serde_json::to_writer_pretty(&mut w, &doc)?;
    writeln!(w)?;
    let file = w.into_inner().map_err(|e| e.into_error())?;
    file.sync_all()?;
    Ok(())
}
