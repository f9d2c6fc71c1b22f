//! The same-driver yardstick of issue 21 item 5: `hard`'s frame drawn twice on this machine's
//! Mesa, once by softshadow (Vulkan, lavapipe) and once through OpenGL 4.5 core (Mesa's
//! llvmpipe behind EGL, no window), with the same scene, camera, light, frame constants and
//! shaders, interleaved round by round so that both see the same load.
//!
//! ```text
//! cargo run --release --example gl_hard_frame -- [--scenes cylinder,overlap,bunny]
//!     [--width 640] [--height 480] [--shadow-res 1024] [--frames 20] [--rounds 5]
//!     [--png DIR]
//! ```
//!
//! A third row draws the GL frame with a lean shader, what a minimal GL shadow-mapping demo
//! shades (`LEAN_FRAG`): the cost of the per-pixel work itself, not the same image.
//!
//! GL side, as an engine draws a hard shadow: pass 1 a depth-only FBO (DEPTH_COMPONENT32F,
//! clear 1, LESS, no colour, no fragment shader, casters only, no culling); pass 2 the camera
//! FBO (RGBA8 + DEPTH_COMPONENT32F, clear, LESS, every object). Both compile the GLSL files
//! the Vulkan build compiles (glsl/hard/shadow_map.vert; glsl/common/scene.vert with
//! glsl/hard/final.frag, which includes common/shadow.glsl and common/final.glsl), with only
//! the Vulkan-only layout qualifiers mapped to GL's (`gl_source`); the push constants become
//! a uniform block holding the same `DrawPush`, and `glClipControl` gives GL Vulkan's depth
//! range. GL times are wall clock, as a GL benchmark measures them: `shadow map`, `camera
//! pass` and `frame` (their sum) with a `glFinish` after each pass, `frame wall` for whole
//! frames with one `glFinish` at the end. Vulkan side: `softshadow`'s GPU timestamps (the
//! bench's protocol) and, as `frame wall`, the wall time of `Renderer::render` (record,
//! submit, wait). Each side: median of `--frames` frames per round, the lowest of `--rounds`
//! round medians. Both images are compared at the end (largest 8-bit difference, pixels off
//! by more than 8 of 255) so that the two sides are known to draw the same frame.
//!
//! Rows: Vulkan rasterizes NDC y = -1 into image row 0, GL into window row 0, which
//! `glReadPixels` returns first: both images come back in the same row order (and the light
//! uv = ndc * 0.5 + 0.5 addresses the same texel row of both shadow maps).

use anyhow::{anyhow, bail, Context as _, Result};
use glow::HasContext;
use khronos_egl as egl;
use softshadow::frustum::fit_light;
use softshadow::gpu::gpu_scene::{DrawPush, DRAW_PUSH_BYTES};
use softshadow::render::{FrameUniforms, Renderer};
use softshadow::scene::Scene;
use softshadow::settings::Settings;
use softshadow::vk::{Context, ContextOptions};
use std::time::Instant;

/// EGL_PLATFORM_SURFACELESS_MESA: a display with no window system.
const PLATFORM_SURFACELESS_MESA: egl::Enum = 0x31DD;
/// `CameraTargets::BACKGROUND`, the clear colour of both sides.
const BACKGROUND: [f32; 4] = [0.05, 0.05, 0.06, 1.0];

/// The GLSL that build.rs compiles for `hard` (glsl/), by the names they `#include` each
/// other by: the GL side compiles these very sources (`gl_source`), not a copy of them.
const SOURCES: &[(&str, &str)] = &[
    (
        "common/frame.glsl",
        include_str!("../glsl/common/frame.glsl"),
    ),
    (
        "common/shadow.glsl",
        include_str!("../glsl/common/shadow.glsl"),
    ),
    (
        "common/final.glsl",
        include_str!("../glsl/common/final.glsl"),
    ),
    (
        "common/scene.vert",
        include_str!("../glsl/common/scene.vert"),
    ),
    (
        "hard/shadow_map.vert",
        include_str!("../glsl/hard/shadow_map.vert"),
    ),
    ("hard/final.frag", include_str!("../glsl/hard/final.frag")),
    ("lean.vert", LEAN_VERT),
    ("lean.frag", LEAN_FRAG),
];

/// The lean variant: what a minimal GL shadow-mapping demo draws per pixel (the light
/// coordinates from the vertex shader, one `textureProj` with a constant depth bias, N.L
/// diffuse, no normal offset, no spot cone, no gamma): the cost of the per-pixel work
/// itself, beside ours. Not the same image.
const LEAN_VERT: &str = r#"#version 450
#include "common/frame.glsl"
layout(location = 0) in vec3 in_pos;
layout(location = 1) in vec3 in_normal;
layout(location = 0) out vec3 v_normal;
layout(location = 1) out vec3 v_to_light;
layout(location = 2) out vec4 v_shadow;
void main() {
    vec4 world = draw.model * vec4(in_pos, 1.0);
    v_normal = mat3(draw.model) * in_normal;
    v_to_light = frame.light_pos_radius.xyz - world.xyz;
    vec4 c = frame.light_view_proj * world;
    v_shadow = vec4((c.xy + c.w) * 0.5, c.z - 1e-3 * c.w, c.w);
    gl_Position = frame.cam_view_proj * world;
}
"#;

const LEAN_FRAG: &str = r#"#version 450
#include "common/frame.glsl"
layout(set = 0, binding = 1) uniform sampler2DShadow shadow_map;
layout(location = 0) in vec3 v_normal;
layout(location = 1) in vec3 v_to_light;
layout(location = 2) in vec4 v_shadow;
layout(location = 0) out vec4 o_color;
void main() {
    float ndl = max(dot(normalize(v_normal), normalize(v_to_light)), 0.0);
    float vis = textureProj(shadow_map, v_shadow);
    o_color = vec4(draw.albedo_receives.rgb * (0.12 + 0.88 * ndl * vis), 1.0);
}
"#;

/// `name` from `SOURCES` as GL 4.5 core compiles it: `#include`s inlined (their guards
/// keep one copy), and the Vulkan-only layout pieces mapped to GL's: no descriptor set (the
/// Frame block stays at binding 0, the map at texture unit 1) and the push constants
/// (`Draw`) as a std140 uniform block at binding 1 (the same layout: a mat4 and two vec4).
fn gl_source(name: &str) -> Result<String> {
    let text = SOURCES
        .iter()
        .find(|(n, _)| *n == name)
        .map(|(_, t)| *t)
        .ok_or_else(|| anyhow!("no GLSL source {name} in SOURCES"))?;
    let mut out = String::new();
    for line in text.lines() {
        if let Some(rest) = line.trim_start().strip_prefix("#include \"") {
            let included = rest.split('"').next().unwrap_or_default();
            out += &gl_source(included)?;
        } else if !line.starts_with("#extension GL_GOOGLE_include_directive") {
            out += &line.replace("set = 0, ", "").replace(
                "layout(push_constant, std430) uniform Draw",
                "layout(std140, binding = 1) uniform Draw",
            );
            out.push('\n');
        }
    }
    Ok(out)
}

/// Command line (`--help` lists it).
#[derive(clap::Parser)]
#[command(
    about = "hard's frame through softshadow (Vulkan) and OpenGL on the same Mesa, interleaved"
)]
struct Args {
    /// Built-in scene names or scene files, comma-separated
    #[arg(long, value_delimiter = ',', default_value = "cylinder,overlap,bunny")]
    scenes: Vec<String>,
    #[arg(long, default_value_t = 640)]
    width: u32,
    #[arg(long, default_value_t = 480)]
    height: u32,
    #[arg(long, default_value_t = 1024)]
    shadow_res: u32,
    /// Timed frames a round and side (after 2 warm-up frames)
    #[arg(long, default_value_t = 20, value_parser = clap::value_parser!(u32).range(1..))]
    frames: u32,
    /// Rounds; each side's figure is the lowest of its round medians
    #[arg(long, default_value_t = 5, value_parser = clap::value_parser!(u32).range(1..))]
    rounds: u32,
    /// Also write both sides' images as DIR/SCENE_vulkan.png and DIR/SCENE_gl.png
    #[arg(long, value_name = "DIR")]
    png: Option<std::path::PathBuf>,
}

fn median(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// One object's GL geometry, and where its `DrawPush` lies in the draw uniform buffer.
struct GlObject {
    vao: glow::VertexArray,
    index_count: i32,
    draw_offset: i32,
    casts: bool,
}

struct GlFrame {
    gl: glow::Context,
    objects: Vec<GlObject>,
    /// Every object's `DrawPush`, bound per draw at binding 1 (the push constants' stand-in).
    draws: glow::Buffer,
    shadow_program: glow::Program,
    /// `hard`'s camera pass, and the lean variant.
    camera_programs: [glow::Program; 2],
    shadow_fbo: glow::Framebuffer,
    camera_fbo: glow::Framebuffer,
    width: i32,
    height: i32,
    shadow_res: i32,
    // Kept alive with the context (EGL objects are released at process exit).
    _egl: (
        egl::DynamicInstance<egl::EGL1_5>,
        egl::Display,
        egl::Context,
    ),
}

/// A program of the named `SOURCES` (`gl_source`), each name's stage by its extension.
fn compile(gl: &glow::Context, names: &[&str]) -> Result<glow::Program> {
    // SAFETY: a current GL context; every object created here is checked before use.
    unsafe {
        let program = gl.create_program().map_err(|e| anyhow!(e))?;
        for &name in names {
            let kind = if name.ends_with(".vert") {
                glow::VERTEX_SHADER
            } else {
                glow::FRAGMENT_SHADER
            };
            let shader = gl.create_shader(kind).map_err(|e| anyhow!(e))?;
            gl.shader_source(shader, &gl_source(name)?);
            gl.compile_shader(shader);
            if !gl.get_shader_compile_status(shader) {
                bail!("GL shader {name}: {}", gl.get_shader_info_log(shader));
            }
            gl.attach_shader(program, shader);
        }
        gl.link_program(program);
        if !gl.get_program_link_status(program) {
            bail!("GL program {names:?}: {}", gl.get_program_info_log(program));
        }
        Ok(program)
    }
}

impl GlFrame {
    fn new(scene: &Scene, settings: &Settings, uniforms: &FrameUniforms) -> Result<Self> {
        // Mesa's software rasterizer (llvmpipe), as lavapipe is on the Vulkan side.
        std::env::set_var("LIBGL_ALWAYS_SOFTWARE", "1");
        // SAFETY: loads the system's libEGL; its functions are called as EGL 1.5 specifies.
        let egl = unsafe { egl::DynamicInstance::<egl::EGL1_5>::load_required() }
            .map_err(|e| anyhow!("loading libEGL.so.1 (Debian: libegl1 libegl-mesa0): {e}"))?;
        // SAFETY: the surfaceless platform takes no native display.
        let display = unsafe {
            egl.get_platform_display(
                PLATFORM_SURFACELESS_MESA,
                egl::DEFAULT_DISPLAY,
                &[egl::ATTRIB_NONE],
            )
        }
        .context("EGL surfaceless display")?;
        egl.initialize(display).context("eglInitialize")?;
        egl.bind_api(egl::OPENGL_API)
            .context("eglBindAPI(OpenGL)")?;
        let config = egl
            .choose_first_config(
                display,
                &[
                    egl::SURFACE_TYPE,
                    egl::PBUFFER_BIT,
                    egl::RENDERABLE_TYPE,
                    egl::OPENGL_BIT,
                    egl::NONE,
                ],
            )
            .context("eglChooseConfig")?
            .ok_or_else(|| anyhow!("no EGL config with OpenGL"))?;
        let context = egl
            .create_context(
                display,
                config,
                None,
                &[
                    egl::CONTEXT_MAJOR_VERSION,
                    4,
                    egl::CONTEXT_MINOR_VERSION,
                    5,
                    egl::CONTEXT_OPENGL_PROFILE_MASK,
                    egl::CONTEXT_OPENGL_CORE_PROFILE_BIT,
                    egl::NONE,
                ],
            )
            .context("creating a GL 4.5 core context")?;
        egl.make_current(display, None, None, Some(context))
            .context("eglMakeCurrent (surfaceless)")?;
        // SAFETY: the context is current; glow resolves every entry point through EGL.
        let gl = unsafe {
            glow::Context::from_loader_function(|name| {
                egl.get_proc_address(name)
                    .map_or(std::ptr::null(), |f| f as *const _)
            })
        };
        let (w, h, res) = (
            settings.width as i32,
            settings.height as i32,
            settings.shadow_res as i32,
        );
        let shadow_program = compile(&gl, &["hard/shadow_map.vert"])?;
        let camera_programs = [
            compile(&gl, &["common/scene.vert", "hard/final.frag"])?,
            compile(&gl, &["lean.vert", "lean.frag"])?,
        ];
        // Vulkan's clip space (glam's projections: z in [0, 1], the depth value as is), so
        // that both sides store and compare the same depths. Core since GL 4.5; glow 0.18
        // does not wrap it.
        let clip_control = egl
            .get_proc_address("glClipControl")
            .ok_or_else(|| anyhow!("no glClipControl"))?;
        // SAFETY: glClipControl(GLenum origin, GLenum depth) is the entry point EGL returned
        // for that name, called with two valid enums on the current context.
        unsafe {
            let clip_control: extern "system" fn(u32, u32) = std::mem::transmute(clip_control);
            clip_control(glow::LOWER_LEFT, glow::ZERO_TO_ONE);
        }
        // SAFETY: the context is current; the data slices outlive the upload calls.
        unsafe {
            let ubo = gl.create_buffer().map_err(|e| anyhow!(e))?;
            gl.bind_buffer(glow::UNIFORM_BUFFER, Some(ubo));
            gl.buffer_data_u8_slice(
                glow::UNIFORM_BUFFER,
                bytemuck::bytes_of(uniforms),
                glow::STATIC_DRAW,
            );
            gl.bind_buffer_base(glow::UNIFORM_BUFFER, 0, Some(ubo));

            // std140 blocks bound by range start at multiples of this.
            let align = gl
                .get_parameter_i32(glow::UNIFORM_BUFFER_OFFSET_ALIGNMENT)
                .max(1) as usize;
            let stride = DRAW_PUSH_BYTES.div_ceil(align as u32) as usize * align;
            let mut draw_bytes = vec![0u8; stride * scene.objects.len()];
            let mut objects = Vec::new();
            for (i, o) in scene.objects.iter().enumerate() {
                let push = DrawPush::new(o.transform, o.albedo, o.role);
                draw_bytes[i * stride..][..DRAW_PUSH_BYTES as usize]
                    .copy_from_slice(bytemuck::bytes_of(&push));
                let m = &o.mesh;
                let vertices: Vec<f32> = m
                    .positions
                    .iter()
                    .zip(&m.normals)
                    .flat_map(|(p, n)| [p.x, p.y, p.z, n.x, n.y, n.z])
                    .collect();
                let vao = gl.create_vertex_array().map_err(|e| anyhow!(e))?;
                gl.bind_vertex_array(Some(vao));
                let vbo = gl.create_buffer().map_err(|e| anyhow!(e))?;
                gl.bind_buffer(glow::ARRAY_BUFFER, Some(vbo));
                gl.buffer_data_u8_slice(
                    glow::ARRAY_BUFFER,
                    bytemuck::cast_slice(&vertices),
                    glow::STATIC_DRAW,
                );
                let ibo = gl.create_buffer().map_err(|e| anyhow!(e))?;
                gl.bind_buffer(glow::ELEMENT_ARRAY_BUFFER, Some(ibo));
                gl.buffer_data_u8_slice(
                    glow::ELEMENT_ARRAY_BUFFER,
                    bytemuck::cast_slice(&m.indices),
                    glow::STATIC_DRAW,
                );
                gl.enable_vertex_attrib_array(0);
                gl.vertex_attrib_pointer_f32(0, 3, glow::FLOAT, false, 24, 0);
                gl.enable_vertex_attrib_array(1);
                gl.vertex_attrib_pointer_f32(1, 3, glow::FLOAT, false, 24, 12);
                objects.push(GlObject {
                    vao,
                    index_count: m.indices.len() as i32,
                    draw_offset: (i * stride) as i32,
                    casts: o.role.casts(),
                });
            }
            let draws = gl.create_buffer().map_err(|e| anyhow!(e))?;
            gl.bind_buffer(glow::UNIFORM_BUFFER, Some(draws));
            gl.buffer_data_u8_slice(glow::UNIFORM_BUFFER, &draw_bytes, glow::STATIC_DRAW);

            let map = gl.create_texture().map_err(|e| anyhow!(e))?;
            gl.bind_texture(glow::TEXTURE_2D, Some(map));
            gl.tex_image_2d(
                glow::TEXTURE_2D,
                0,
                glow::DEPTH_COMPONENT32F as i32,
                res,
                res,
                0,
                glow::DEPTH_COMPONENT,
                glow::FLOAT,
                glow::PixelUnpackData::Slice(None),
            );
            for (p, v) in [
                (glow::TEXTURE_MIN_FILTER, glow::LINEAR),
                (glow::TEXTURE_MAG_FILTER, glow::LINEAR),
                (glow::TEXTURE_WRAP_S, glow::CLAMP_TO_EDGE),
                (glow::TEXTURE_WRAP_T, glow::CLAMP_TO_EDGE),
                (glow::TEXTURE_COMPARE_MODE, glow::COMPARE_REF_TO_TEXTURE),
                (glow::TEXTURE_COMPARE_FUNC, glow::LEQUAL),
            ] {
                gl.tex_parameter_i32(glow::TEXTURE_2D, p, v as i32);
            }
            gl.tex_parameter_i32(glow::TEXTURE_2D, glow::TEXTURE_MAX_LEVEL, 0);
            let shadow_fbo = gl.create_framebuffer().map_err(|e| anyhow!(e))?;
            gl.bind_framebuffer(glow::FRAMEBUFFER, Some(shadow_fbo));
            gl.framebuffer_texture_2d(
                glow::FRAMEBUFFER,
                glow::DEPTH_ATTACHMENT,
                glow::TEXTURE_2D,
                Some(map),
                0,
            );
            gl.draw_buffer(glow::NONE);
            gl.read_buffer(glow::NONE);
            if gl.check_framebuffer_status(glow::FRAMEBUFFER) != glow::FRAMEBUFFER_COMPLETE {
                bail!("shadow FBO incomplete");
            }

            let camera_fbo = gl.create_framebuffer().map_err(|e| anyhow!(e))?;
            gl.bind_framebuffer(glow::FRAMEBUFFER, Some(camera_fbo));
            for (format, attachment) in [
                (glow::RGBA8, glow::COLOR_ATTACHMENT0),
                (glow::DEPTH_COMPONENT32F, glow::DEPTH_ATTACHMENT),
            ] {
                let rb = gl.create_renderbuffer().map_err(|e| anyhow!(e))?;
                gl.bind_renderbuffer(glow::RENDERBUFFER, Some(rb));
                gl.renderbuffer_storage(glow::RENDERBUFFER, format, w, h);
                gl.framebuffer_renderbuffer(
                    glow::FRAMEBUFFER,
                    attachment,
                    glow::RENDERBUFFER,
                    Some(rb),
                );
            }
            if gl.check_framebuffer_status(glow::FRAMEBUFFER) != glow::FRAMEBUFFER_COMPLETE {
                bail!("camera FBO incomplete");
            }
            // The shaders' `binding = 1` for the map: texture unit 1.
            gl.active_texture(glow::TEXTURE1);
            gl.bind_texture(glow::TEXTURE_2D, Some(map));
            gl.enable(glow::DEPTH_TEST);
            gl.depth_func(glow::LESS);
            gl.disable(glow::CULL_FACE);

            Ok(Self {
                gl,
                objects,
                draws,
                shadow_program,
                camera_programs,
                shadow_fbo,
                camera_fbo,
                width: w,
                height: h,
                shadow_res: res,
                _egl: (egl, display, context),
            })
        }
    }

    fn draw(&self, casters_only: bool) {
        let gl = &self.gl;
        // SAFETY: the context is current; every object was created by it, and each range
        // lies inside `draws`.
        unsafe {
            for o in self.objects.iter().filter(|o| o.casts || !casters_only) {
                gl.bind_buffer_range(
                    glow::UNIFORM_BUFFER,
                    1,
                    Some(self.draws),
                    o.draw_offset,
                    DRAW_PUSH_BYTES as i32,
                );
                gl.bind_vertex_array(Some(o.vao));
                gl.draw_elements(glow::TRIANGLES, o.index_count, glow::UNSIGNED_INT, 0);
            }
        }
    }

    fn shadow_pass(&self) {
        let gl = &self.gl;
        // SAFETY: the context is current.
        unsafe {
            gl.bind_framebuffer(glow::FRAMEBUFFER, Some(self.shadow_fbo));
            gl.viewport(0, 0, self.shadow_res, self.shadow_res);
            gl.clear_depth_f32(1.0);
            gl.clear(glow::DEPTH_BUFFER_BIT);
            gl.use_program(Some(self.shadow_program));
        }
        self.draw(true);
    }

    /// `lean`: the lean variant's program instead of `hard`'s.
    fn camera_pass(&self, lean: bool) {
        let gl = &self.gl;
        let [r, g, b, a] = BACKGROUND;
        // SAFETY: the context is current.
        unsafe {
            gl.bind_framebuffer(glow::FRAMEBUFFER, Some(self.camera_fbo));
            gl.viewport(0, 0, self.width, self.height);
            gl.clear_color(r, g, b, a);
            gl.clear(glow::COLOR_BUFFER_BIT | glow::DEPTH_BUFFER_BIT);
            gl.use_program(Some(self.camera_programs[usize::from(lean)]));
        }
        self.draw(false);
    }

    fn finish(&self) {
        // SAFETY: the context is current.
        unsafe { self.gl.finish() }
    }

    /// The colour target, rows in the order of `Renderer::read_color`.
    fn read_color(&self) -> Vec<[u8; 4]> {
        let (w, h) = (self.width as usize, self.height as usize);
        let mut bytes = vec![0u8; w * h * 4];
        // SAFETY: the context is current; `bytes` holds w x h RGBA8 texels.
        unsafe {
            self.gl
                .bind_framebuffer(glow::FRAMEBUFFER, Some(self.camera_fbo));
            self.gl.read_pixels(
                0,
                0,
                self.width,
                self.height,
                glow::RGBA,
                glow::UNSIGNED_BYTE,
                glow::PixelPackData::Slice(Some(&mut bytes)),
            );
        }
        bytes.chunks(4).map(|p| [p[0], p[1], p[2], p[3]]).collect()
    }
}

/// Per-round medians, milliseconds.
#[derive(Default)]
struct Lowest {
    shadow: Vec<f64>,
    camera: Vec<f64>,
    frame: Vec<f64>,
    wall: Vec<f64>,
}

impl Lowest {
    fn min(v: &[f64]) -> f64 {
        v.iter().copied().fold(f64::INFINITY, f64::min)
    }
}

fn main() {
    if let Err(e) = run(<Args as clap::Parser>::parse()) {
        eprintln!("error: {e:#}");
        std::process::exit(1);
    }
}

fn run(args: Args) -> Result<()> {
    let ctx = Context::new(&ContextOptions::from_env())?;
    println!("vulkan: {}", ctx.describe());
    println!(
        "{}x{}, {}^2 map, {} frames x {} rounds, lowest round median, ms",
        args.width, args.height, args.shadow_res, args.frames, args.rounds
    );
    println!(
        "| scene | side | shadow map | camera pass | frame | frame wall | max diff | pixels > 8 |"
    );
    println!("|:---|:---|---:|---:|---:|---:|---:|---:|");
    let mut gl_described = false;
    for name in &args.scenes {
        let scene = Scene::load(name)?;
        let settings = Settings {
            width: args.width,
            height: args.height,
            shadow_res: args.shadow_res,
            cache_light_passes: false,
            ..Settings::default()
        };
        let mut vk = Renderer::new(&ctx, scene.clone(), "hard", settings.clone())?;
        let light = fit_light(&scene);
        let uniforms = FrameUniforms::new(
            &scene,
            &settings,
            &light,
            settings.radius_for(&scene),
            [[0.0; 4]; 2],
        );
        let gl = GlFrame::new(&scene, &settings, &uniforms)?;
        if !gl_described {
            // SAFETY: the context is current.
            let (renderer, version) = unsafe {
                (
                    gl.gl.get_parameter_string(glow::RENDERER),
                    gl.gl.get_parameter_string(glow::VERSION),
                )
            };
            eprintln!("gl: {renderer}, {version}");
            gl_described = true;
        }
        let (mut v, mut g, mut lean_gl) = (Lowest::default(), Lowest::default(), Lowest::default());
        for _ in 0..args.rounds {
            // Vulkan: GPU timestamps per pass and the frame, and render()'s wall time.
            let (mut s, mut c, mut f, mut w) = (vec![], vec![], vec![], vec![]);
            for i in 0..args.frames + 2 {
                let t = Instant::now();
                let timings = vk.render()?;
                let wall = t.elapsed().as_secs_f64() * 1e3;
                if i < 2 {
                    continue;
                }
                let pass = |n: &str| {
                    timings
                        .passes
                        .iter()
                        .find(|p| p.name == n)
                        .and_then(|p| p.gpu_ms)
                        .unwrap_or(f64::NAN)
                };
                s.push(pass("hard/shadow_map"));
                c.push(pass("hard/final"));
                f.push(timings.gpu_frame_ms.unwrap_or(f64::NAN));
                w.push(wall);
            }
            v.shadow.push(median(&mut s));
            v.camera.push(median(&mut c));
            v.frame.push(median(&mut f));
            v.wall.push(median(&mut w));
            // GL, hard's shaders then the lean variant: glFinish after each pass, then whole
            // frames with one glFinish each.
            for (lean, l) in [(false, &mut g), (true, &mut lean_gl)] {
                let (mut s, mut c, mut f, mut w) = (vec![], vec![], vec![], vec![]);
                for i in 0..args.frames + 2 {
                    let t0 = Instant::now();
                    gl.shadow_pass();
                    gl.finish();
                    let t1 = Instant::now();
                    gl.camera_pass(lean);
                    gl.finish();
                    let t2 = Instant::now();
                    if i >= 2 {
                        s.push((t1 - t0).as_secs_f64() * 1e3);
                        c.push((t2 - t1).as_secs_f64() * 1e3);
                        f.push((t2 - t0).as_secs_f64() * 1e3);
                    }
                }
                for _ in 0..args.frames {
                    let t0 = Instant::now();
                    gl.shadow_pass();
                    gl.camera_pass(lean);
                    gl.finish();
                    w.push(t0.elapsed().as_secs_f64() * 1e3);
                }
                l.shadow.push(median(&mut s));
                l.camera.push(median(&mut c));
                l.frame.push(median(&mut f));
                l.wall.push(median(&mut w));
            }
        }
        // hard's shaders' image, for the comparison.
        gl.shadow_pass();
        gl.camera_pass(false);
        gl.finish();
        let ours = vk.read_color()?;
        let theirs = gl.read_color();
        if let Some(dir) = &args.png {
            for (side, px) in [("vulkan", &ours), ("gl", &theirs)] {
                let bytes: Vec<u8> = px.iter().flatten().copied().collect();
                let path = dir.join(format!("{name}_{side}.png"));
                image::RgbaImage::from_raw(args.width, args.height, bytes)
                    .ok_or_else(|| anyhow!("image size"))?
                    .save(&path)
                    .with_context(|| format!("writing {}", path.display()))?;
            }
        }
        let (mut max, mut off) = (0u8, 0usize);
        for (a, b) in ours.iter().zip(&theirs) {
            let d = (0..3).map(|k| a[k].abs_diff(b[k])).max().unwrap_or(0);
            max = max.max(d);
            off += usize::from(d > 8);
        }
        for (side, l, diff) in [
            ("vulkan (lavapipe), GPU timestamps", &v, String::new()),
            ("GL 4.5 (llvmpipe), glFinish", &g, format!("{max} | {off}")),
            (
                "GL 4.5 (llvmpipe), glFinish, lean shader",
                &lean_gl,
                String::new(),
            ),
        ] {
            let diff = if diff.is_empty() {
                "– | –".to_string()
            } else {
                diff
            };
            println!(
                "| {name} | {side} | {:.2} | {:.2} | {:.2} | {:.2} | {diff} |",
                Lowest::min(&l.shadow),
                Lowest::min(&l.camera),
                Lowest::min(&l.frame),
                Lowest::min(&l.wall),
            );
        }
    }
    Ok(())
}
