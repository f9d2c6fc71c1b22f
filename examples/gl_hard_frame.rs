//! The same-driver yardstick of issue 21 item 5: `hard`'s frame drawn twice on this machine's
//! Mesa, once by softshadow (Vulkan, lavapipe) and once by a plain OpenGL 3.3 core
//! implementation (Mesa's llvmpipe behind EGL, no window), with the same scene, camera,
//! light, frame constants and per-pixel work, interleaved round by round so that both see
//! the same load.
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
//! FBO (RGBA8 + DEPTH_COMPONENT32F, clear, LESS, every object), its fragment shader a line for
//! line GLSL 330 port of glsl/hard/final.frag + common/shadow.glsl + common/final.glsl
//! sampling the map through a `sampler2DShadow` (LEQUAL, linear). GL times are wall clock,
//! as a GL benchmark measures them: `shadow map`, `camera pass` and `frame` (their sum) with
//! a `glFinish` after each pass, `frame wall` for whole frames with one `glFinish` at the
//! end. Vulkan side: `softshadow`'s GPU timestamps (the bench's protocol) and, as `frame
//! wall`, the wall time of `Renderer::render` (record, submit, wait). Each side: median of `--frames` frames per round, the lowest of `--rounds`
//! round medians. Both images are compared at the end (largest 8-bit difference, pixels off
//! by more than 8 of 255) so that the two sides are known to draw the same frame.
//!
//! Clip-space depth: glam's projections give z in [0, 1] (Vulkan); GL maps [-1, 1] to the
//! depth range, so both vertex shaders write z' = 2z - w to store the same depth values.
//! Rows: Vulkan rasterizes NDC y = -1 into image row 0, GL into window row 0, which
//! `glReadPixels` returns first: both images come back in the same row order (and the light
//! uv = ndc * 0.5 + 0.5 addresses the same texel row of both shadow maps).

use anyhow::{anyhow, bail, Context as _, Result};
use glow::HasContext;
use khronos_egl as egl;
use softshadow::frustum::fit_light;
use softshadow::render::{FrameUniforms, Renderer};
use softshadow::scene::Scene;
use softshadow::settings::Settings;
use softshadow::vk::{Context, ContextOptions};
use std::time::Instant;

/// EGL_PLATFORM_SURFACELESS_MESA: a display with no window system.
const PLATFORM_SURFACELESS_MESA: egl::Enum = 0x31DD;
/// `CameraTargets::BACKGROUND`, the clear colour of both sides.
const BACKGROUND: [f32; 4] = [0.05, 0.05, 0.06, 1.0];

const FRAME_BLOCK: &str = r#"
layout(std140) uniform Frame {
    mat4 cam_view_proj;
    mat4 light_view;
    mat4 light_view_proj;
    vec4 light_pos_radius;
    vec4 cam_pos;
    vec4 light_params;
    vec4 light_frustum;
    vec4 technique;
    vec4 technique2;
} frame;
uniform mat4 model;
uniform vec4 albedo_receives;
uniform vec4 flags;
"#;

const SHADOW_VERT: &str = r#"
layout(location = 0) in vec3 in_pos;
void main() {
    vec4 c = frame.light_view_proj * (model * vec4(in_pos, 1.0));
    gl_Position = vec4(c.xy, 2.0 * c.z - c.w, c.w);
}
"#;

const SCENE_VERT: &str = r#"
layout(location = 0) in vec3 in_pos;
layout(location = 1) in vec3 in_normal;
out vec3 v_world;
out vec3 v_normal;
out vec4 v_light_clip;
out vec4 v_light_normal;
void main() {
    vec4 world = model * vec4(in_pos, 1.0);
    v_world = world.xyz;
    v_normal = transpose(inverse(mat3(model))) * in_normal;
    v_light_clip = frame.light_view_proj * world;
    v_light_normal = frame.light_view_proj * vec4(v_normal, 0.0);
    vec4 c = frame.cam_view_proj * world;
    gl_Position = vec4(c.xy, 2.0 * c.z - c.w, c.w);
}
"#;

const HARD_FRAG: &str = r#"
uniform sampler2DShadow shadow_map;
in vec3 v_world;
in vec3 v_normal;
in vec4 v_light_clip;
in vec4 v_light_normal;
layout(location = 0) out vec4 o_color;
vec4 surface_light_clip;
vec4 surface_light_normal;
struct LightSample { vec2 uv; float depth; bool inside; };
LightSample light_sample(vec3 p, vec3 n) {
    float d0 = surface_light_clip.w;
    vec3 l = normalize(frame.light_pos_radius.xyz - p);
    float slope = clamp(sqrt(max(1.0 - dot(n, l) * dot(n, l), 0.0)), 0.2, 1.0);
    float k = d0 * frame.light_frustum.y * frame.light_frustum.z * slope;
    vec4 c = surface_light_clip + surface_light_normal * k;
    LightSample s;
    s.depth = c.w;
    s.uv = (c.xy / max(c.w, 1e-30)) * 0.5 + 0.5;
    s.inside = c.w > frame.light_params.x && all(greaterThanEqual(s.uv, vec2(0.0))) && all(lessThanEqual(s.uv, vec2(1.0)));
    return s;
}
float visibility(vec3 p, vec3 n) {
    LightSample s = light_sample(p, n);
    if (!s.inside) return 1.0;
    float near = frame.light_params.x, far = frame.light_params.y;
    float d = s.depth / (1.0 + frame.light_frustum.w);
    float z = far / (far - near) * (1.0 - near / d);
    return texture(shadow_map, vec3(s.uv, z));
}
void main() {
    vec3 n = normalize(v_normal);
    float side = dot(n, frame.cam_pos.xyz - v_world) < 0.0 ? -1.0 : 1.0;
    n *= side;
    surface_light_clip = v_light_clip;
    surface_light_normal = v_light_normal * (side * inversesqrt(dot(v_normal, v_normal)));
    float vis = albedo_receives.w > 0.5 ? visibility(v_world, n) : 1.0;
    vec3 l = normalize(frame.light_pos_radius.xyz - v_world);
    float ndl = max(dot(n, l), 0.0);
    vec4 c = v_light_clip;
    vec2 ndc = c.xy / max(c.w, 1e-30);
    float spot = c.w > 0.0 ? 1.0 - smoothstep(0.85, 1.0, max(abs(ndc.x), abs(ndc.y))) : 0.0;
    float k = 0.12 + 0.88 * ndl * vis * spot;
    o_color = vec4(min(flags.yzw * pow(k, 1.0 / 2.2), vec3(1.0)), 1.0);
}
"#;

/// The lean variant: what a minimal GL shadow-mapping demo draws per pixel (the light
/// coordinates from the vertex shader, one `textureProj` with a constant depth bias, N.L
/// diffuse, no normal offset, no spot cone, no gamma): the cost of the per-pixel work
/// itself, beside the port above. Not the same image.
const LEAN_VERT: &str = r#"
layout(location = 0) in vec3 in_pos;
layout(location = 1) in vec3 in_normal;
out vec3 v_normal;
out vec3 v_to_light;
out vec4 v_shadow;
void main() {
    vec4 world = model * vec4(in_pos, 1.0);
    v_normal = mat3(model) * in_normal;
    v_to_light = frame.light_pos_radius.xyz - world.xyz;
    vec4 c = frame.light_view_proj * world;
    v_shadow = vec4((c.xy + c.w) * 0.5, c.z - 1e-3 * c.w, c.w);
    vec4 p = frame.cam_view_proj * world;
    gl_Position = vec4(p.xy, 2.0 * p.z - p.w, p.w);
}
"#;

const LEAN_FRAG: &str = r#"
uniform sampler2DShadow shadow_map;
in vec3 v_normal;
in vec3 v_to_light;
in vec4 v_shadow;
layout(location = 0) out vec4 o_color;
void main() {
    float ndl = max(dot(normalize(v_normal), normalize(v_to_light)), 0.0);
    float vis = textureProj(shadow_map, v_shadow);
    o_color = vec4(albedo_receives.rgb * (0.12 + 0.88 * ndl * vis), 1.0);
}
"#;

/// Command line (`--help` lists it).
#[derive(clap::Parser)]
#[command(
    about = "hard's frame through softshadow (Vulkan) and OpenGL 3.3 on the same Mesa, interleaved"
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

/// One object's GL geometry and per-draw constants.
struct GlObject {
    vao: glow::VertexArray,
    index_count: i32,
    model: [f32; 16],
    albedo_receives: [f32; 4],
    flags: [f32; 4],
    casts: bool,
}

struct GlFrame {
    gl: glow::Context,
    objects: Vec<GlObject>,
    shadow_program: glow::Program,
    /// The port of `hard`'s camera pass, and the lean variant.
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

fn compile(gl: &glow::Context, stages: &[(u32, &str)]) -> Result<glow::Program> {
    // SAFETY: a current GL context; every object created here is checked before use.
    unsafe {
        let program = gl.create_program().map_err(|e| anyhow!(e))?;
        for &(kind, body) in stages {
            let shader = gl.create_shader(kind).map_err(|e| anyhow!(e))?;
            gl.shader_source(shader, &format!("#version 330 core\n{FRAME_BLOCK}{body}"));
            gl.compile_shader(shader);
            if !gl.get_shader_compile_status(shader) {
                bail!("GL shader: {}", gl.get_shader_info_log(shader));
            }
            gl.attach_shader(program, shader);
        }
        gl.link_program(program);
        if !gl.get_program_link_status(program) {
            bail!("GL program: {}", gl.get_program_info_log(program));
        }
        let block = gl
            .get_uniform_block_index(program, "Frame")
            .ok_or_else(|| anyhow!("no Frame block"))?;
        gl.uniform_block_binding(program, block, 0);
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
                    3,
                    egl::CONTEXT_MINOR_VERSION,
                    3,
                    egl::CONTEXT_OPENGL_PROFILE_MASK,
                    egl::CONTEXT_OPENGL_CORE_PROFILE_BIT,
                    egl::NONE,
                ],
            )
            .context("creating a GL 3.3 core context")?;
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
        let shadow_program = compile(&gl, &[(glow::VERTEX_SHADER, SHADOW_VERT)])?;
        let camera_programs = [
            compile(
                &gl,
                &[
                    (glow::VERTEX_SHADER, SCENE_VERT),
                    (glow::FRAGMENT_SHADER, HARD_FRAG),
                ],
            )?,
            compile(
                &gl,
                &[
                    (glow::VERTEX_SHADER, LEAN_VERT),
                    (glow::FRAGMENT_SHADER, LEAN_FRAG),
                ],
            )?,
        ];
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

            let mut objects = Vec::new();
            for o in &scene.objects {
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
                let a = o.albedo;
                let g = 1.0 / 2.2;
                objects.push(GlObject {
                    vao,
                    index_count: m.indices.len() as i32,
                    model: o.transform.to_cols_array(),
                    albedo_receives: [a.x, a.y, a.z, if o.role.receives() { 1.0 } else { 0.0 }],
                    flags: [
                        if o.role.casts() { 1.0 } else { 0.0 },
                        a.x.powf(g),
                        a.y.powf(g),
                        a.z.powf(g),
                    ],
                    casts: o.role.casts(),
                });
            }

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
            for program in camera_programs {
                gl.use_program(Some(program));
                gl.uniform_1_i32(gl.get_uniform_location(program, "shadow_map").as_ref(), 0);
            }
            gl.active_texture(glow::TEXTURE0);
            gl.bind_texture(glow::TEXTURE_2D, Some(map));
            gl.enable(glow::DEPTH_TEST);
            gl.depth_func(glow::LESS);
            gl.disable(glow::CULL_FACE);

            Ok(Self {
                gl,
                objects,
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

    fn draw(&self, program: glow::Program, casters_only: bool) {
        let gl = &self.gl;
        // SAFETY: the context is current; every object was created by it.
        unsafe {
            let model = gl.get_uniform_location(program, "model");
            let albedo = gl.get_uniform_location(program, "albedo_receives");
            let flags = gl.get_uniform_location(program, "flags");
            for o in self.objects.iter().filter(|o| o.casts || !casters_only) {
                gl.uniform_matrix_4_f32_slice(model.as_ref(), false, &o.model);
                gl.uniform_4_f32_slice(albedo.as_ref(), &o.albedo_receives);
                gl.uniform_4_f32_slice(flags.as_ref(), &o.flags);
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
        self.draw(self.shadow_program, true);
    }

    /// `lean`: the lean variant's program instead of the port's.
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
        self.draw(self.camera_programs[usize::from(lean)], false);
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
            // GL, the port then the lean variant: glFinish after each pass, then whole
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
        // The port's image, for the comparison.
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
            ("GL 3.3 (llvmpipe), glFinish", &g, format!("{max} | {off}")),
            (
                "GL 3.3 (llvmpipe), glFinish, lean shader",
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
