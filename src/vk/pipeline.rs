//! Shader modules, descriptor sets and pipelines. Each pipeline is made from one plain
//! description struct (no shared template mutated between pipelines); dynamic rendering
//! (Vulkan 1.3), so no render-pass or framebuffer objects.

use super::context::{Context, Shared};
use super::describe::{
    BindingInfo, BlendInfo, DepthInfo, PipelineInfo, SetInfo, StageInfo, UseInfo,
};
use super::memory::{Buffer, Image, Sampler};
use super::reflect::{self, HostBinding};
use super::sync::{reflect as reflect_uses, BindingUse, Target};
use anyhow::{bail, Context as _, Result};
use ash::vk;
use std::sync::Arc;

/// Creates the module, checks the bindings it declares against `sets` by name and kind
/// (`reflect::check`), and adds the bindings it uses to `uses` (what barriers derive from).
fn shader_module(
    ctx: &Context,
    spirv: &[u8],
    name: &str,
    sets: &[&DescriptorSet],
    uses: &mut Vec<BindingUse>,
) -> Result<vk::ShaderModule> {
    let words = ash::util::read_spv(&mut std::io::Cursor::new(spirv))
        .with_context(|| format!("reading SPIR-V of {name}"))?;
    let declared =
        reflect::bindings(&words).with_context(|| format!("reflecting the SPIR-V of {name}"))?;
    let host: Vec<Vec<HostBinding>> = sets.iter().map(|s| s.host_bindings()).collect();
    let host: Vec<&[HostBinding]> = host.iter().map(Vec::as_slice).collect();
    reflect::check(&declared, &host).with_context(|| {
        let names: Vec<&str> = sets.iter().map(|s| s.name.as_str()).collect();
        format!("{name} against its descriptor sets {names:?}")
    })?;
    reflect_uses(&words, uses).with_context(|| format!("reflecting the SPIR-V of {name}"))?;
    let info = vk::ShaderModuleCreateInfo::default().code(&words);
    // SAFETY: `words` is SPIR-V produced and validated by build.rs.
    unsafe { ctx.device().create_shader_module(&info, None) }
        .with_context(|| format!("creating shader module {name}"))
}

/// What a descriptor binding holds; every binding is visible to all graphics and compute stages.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BindingKind {
    UniformBuffer,
    StorageBuffer,
    SampledImage,
    StorageImage,
}

impl BindingKind {
    fn vk(self) -> vk::DescriptorType {
        match self {
            BindingKind::UniformBuffer => vk::DescriptorType::UNIFORM_BUFFER,
            BindingKind::StorageBuffer => vk::DescriptorType::STORAGE_BUFFER,
            BindingKind::SampledImage => vk::DescriptorType::COMBINED_IMAGE_SAMPLER,
            BindingKind::StorageImage => vk::DescriptorType::STORAGE_IMAGE,
        }
    }
}

/// One resource for a binding. `DescriptorSet::new` takes them in binding order, each
/// with the name of the shader variable it is for.
pub enum Resource<'a> {
    Uniform(&'a Buffer),
    Storage(&'a Buffer),
    /// Sampled in SHADER_READ_ONLY_OPTIMAL.
    Sampled(&'a Image, &'a Sampler),
    /// Used in GENERAL.
    StorageImage(&'a Image),
}

impl Resource<'_> {
    fn kind(&self) -> BindingKind {
        match self {
            Resource::Uniform(_) => BindingKind::UniformBuffer,
            Resource::Storage(_) => BindingKind::StorageBuffer,
            Resource::Sampled(..) => BindingKind::SampledImage,
            Resource::StorageImage(_) => BindingKind::StorageImage,
        }
    }

    /// What a port sheet says is bound: the resource, and an image's format and a
    /// sampler's state.
    fn describe(&self) -> (String, String) {
        match self {
            Resource::Uniform(b) | Resource::Storage(b) => {
                (format!("buffer '{}'", b.name), String::new())
            }
            Resource::Sampled(img, s) => (
                format!("image '{}'", img.name),
                format!("{:?}, sampler {}", img.format, s.description),
            ),
            Resource::StorageImage(img) => {
                (format!("image '{}'", img.name), format!("{:?}", img.format))
            }
        }
    }
}

/// A descriptor-set layout with one set allocated from its own pool, written once: the
/// resources a pass reads never change between frames (only their contents do).
pub struct DescriptorSet {
    shared: Arc<Shared>,
    pub(crate) layout: vk::DescriptorSetLayout,
    pool: vk::DescriptorPool,
    pub(crate) set: vk::DescriptorSet,
    /// What each binding holds, in binding order, for the barriers of the commands using it.
    pub(crate) bindings: Arc<[(BindingKind, Target)]>,
    /// The shader variable each binding is for, in binding order.
    names: Vec<&'static str>,
    /// For errors: which set this is.
    pub name: String,
    /// What it was made with, for the port sheets.
    pub(crate) info: Arc<SetInfo>,
}

impl DescriptorSet {
    /// Bindings 0..n take `resources` in order, each named by the shader variable it is for:
    /// the GLSL instance name (`uniform Frame { .. } frame;` is `frame`, `uniform sampler2D
    /// shadow_map;` is `shadow_map`), or the block's type name when the instance is anonymous
    /// (`buffer Edges { .. };` is `Edges`). Every pipeline made with the set checks each
    /// binding its shaders declare against these names and kinds (`reflect::check`).
    #[track_caller]
    pub fn new(ctx: &Context, named: &[(&'static str, Resource<'_>)], name: &str) -> Result<Self> {
        let info = Arc::new(SetInfo {
            name: name.to_string(),
            bindings: named
                .iter()
                .enumerate()
                .map(|(i, (n, r))| {
                    let (resource, detail) = r.describe();
                    BindingInfo {
                        binding: i as u32,
                        name: n,
                        kind: r.kind(),
                        resource,
                        detail,
                    }
                })
                .collect(),
            made_in: std::panic::Location::caller().file(),
        });
        let names: Vec<&'static str> = named.iter().map(|(n, _)| *n).collect();
        let resources: Vec<&Resource<'_>> = named.iter().map(|(_, r)| r).collect();
        let device = ctx.device();
        let stages = vk::ShaderStageFlags::ALL_GRAPHICS | vk::ShaderStageFlags::COMPUTE;
        let bindings: Vec<_> = resources
            .iter()
            .enumerate()
            .map(|(i, r)| {
                vk::DescriptorSetLayoutBinding::default()
                    .binding(i as u32)
                    .descriptor_type(r.kind().vk())
                    .descriptor_count(1)
                    .stage_flags(stages)
            })
            .collect();
        let layout_info = vk::DescriptorSetLayoutCreateInfo::default().bindings(&bindings);
        // SAFETY: valid create info; destroyed in Drop.
        let layout = unsafe { device.create_descriptor_set_layout(&layout_info, None) }
            .with_context(|| format!("creating descriptor set layout for {name}"))?;
        let sizes: Vec<_> = bindings
            .iter()
            .map(|b| {
                vk::DescriptorPoolSize::default()
                    .ty(b.descriptor_type)
                    .descriptor_count(1)
            })
            .collect();
        let pool_info = vk::DescriptorPoolCreateInfo::default()
            .max_sets(1)
            .pool_sizes(&sizes);
        // SAFETY: valid create info.
        let pool = match unsafe { device.create_descriptor_pool(&pool_info, None) } {
            Ok(p) => p,
            Err(e) => {
                // SAFETY: unused layout.
                unsafe { device.destroy_descriptor_set_layout(layout, None) };
                return Err(e).with_context(|| format!("creating descriptor pool for {name}"));
            }
        };
        let mut this = Self {
            shared: ctx.shared.clone(),
            layout,
            pool,
            set: vk::DescriptorSet::null(),
            bindings: resources
                .iter()
                .map(|r| {
                    let target = match r {
                        Resource::Uniform(b) | Resource::Storage(b) => b.target(),
                        Resource::Sampled(img, _) | Resource::StorageImage(img) => img.target(),
                    };
                    (r.kind(), target)
                })
                .collect(),
            names,
            name: name.to_string(),
            info,
        };
        let layouts = [layout];
        let alloc = vk::DescriptorSetAllocateInfo::default()
            .descriptor_pool(pool)
            .set_layouts(&layouts);
        // SAFETY: the pool has room for exactly this set.
        this.set = unsafe { device.allocate_descriptor_sets(&alloc) }
            .with_context(|| format!("allocating descriptor set for {name}"))?[0];

        let buffer_infos: Vec<_> = resources
            .iter()
            .map(|r| match r {
                Resource::Uniform(b) | Resource::Storage(b) => vk::DescriptorBufferInfo::default()
                    .buffer(b.raw)
                    .offset(0)
                    .range(vk::WHOLE_SIZE),
                _ => vk::DescriptorBufferInfo::default(),
            })
            .collect();
        let image_infos: Vec<_> = resources
            .iter()
            .map(|r| match r {
                Resource::Sampled(img, s) => vk::DescriptorImageInfo::default()
                    .image_view(img.view)
                    .sampler(s.raw)
                    .image_layout(vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL),
                Resource::StorageImage(img) => vk::DescriptorImageInfo::default()
                    .image_view(img.view)
                    .image_layout(vk::ImageLayout::GENERAL),
                _ => vk::DescriptorImageInfo::default(),
            })
            .collect();
        let writes: Vec<_> = resources
            .iter()
            .enumerate()
            .map(|(i, r)| {
                let w = vk::WriteDescriptorSet::default()
                    .dst_set(this.set)
                    .dst_binding(i as u32)
                    .descriptor_type(r.kind().vk());
                match r {
                    Resource::Uniform(_) | Resource::Storage(_) => {
                        w.buffer_info(std::slice::from_ref(&buffer_infos[i]))
                    }
                    _ => w.image_info(std::slice::from_ref(&image_infos[i])),
                }
            })
            .collect();
        // SAFETY: every write references live resources and matches the layout.
        unsafe { device.update_descriptor_sets(&writes, &[]) };
        Ok(this)
    }

    /// Kind and name of each binding, in binding order.
    fn host_bindings(&self) -> Vec<HostBinding> {
        self.bindings
            .iter()
            .zip(&self.names)
            .map(|(&(kind, _), &name)| HostBinding { kind, name })
            .collect()
    }
}

impl Drop for DescriptorSet {
    fn drop(&mut self) {
        // SAFETY: no pending command buffer uses the set; the pool frees it.
        unsafe {
            self.shared.device.destroy_descriptor_pool(self.pool, None);
            self.shared
                .device
                .destroy_descriptor_set_layout(self.layout, None);
        }
    }
}

/// Blending of one colour attachment.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Blend {
    /// Overwrite.
    None,
    /// dst = min(src, dst): darkest wins (smoothie alpha and depth, shadow-map depth).
    Min,
    /// dst = max(src, dst).
    Max,
    /// dst = src + dst: accumulation (soft shadow maps).
    Add,
    /// dst = src | dst on an integer attachment (bitmasks): the logic op OR, which is one
    /// state for the whole pipeline, so every attachment of such a pipeline must be `Or`.
    /// Needs the `logicOp` device feature (`Context::logic_op`).
    Or,
}

/// One vertex attribute: location, format, byte offset.
pub type Attribute = (u32, vk::Format, u32);

/// Everything one graphics pipeline needs, written out in full at each pipeline.
pub struct GraphicsPipelineDesc<'a> {
    pub name: &'a str,
    pub vertex: &'a [u8],
    pub fragment: Option<&'a [u8]>,
    /// Bytes per vertex of binding 0 (0 = no vertex input).
    pub vertex_stride: u32,
    pub attributes: &'a [Attribute],
    pub topology: vk::PrimitiveTopology,
    pub cull: vk::CullModeFlags,
    /// Colour attachments in order, each with its blend.
    pub colors: &'a [(vk::Format, Blend)],
    pub depth: Option<DepthState>,
    pub push_constant_bytes: u32,
    pub sets: &'a [&'a DescriptorSet],
}

#[derive(Clone, Copy, Debug)]
pub struct DepthState {
    pub format: vk::Format,
    pub test: bool,
    pub write: bool,
    pub compare: vk::CompareOp,
}

pub struct Pipeline {
    shared: Arc<Shared>,
    pub(crate) raw: vk::Pipeline,
    pub(crate) layout: vk::PipelineLayout,
    pub(crate) bind_point: vk::PipelineBindPoint,
    /// The descriptor bindings its shaders use, by stage (from their SPIR-V).
    pub(crate) uses: Arc<[BindingUse]>,
    /// Whether it reads vertex buffer 0 (a pipeline pulling vertices from storage does not).
    pub(crate) vertex_input: bool,
    /// Its counting build, bound instead of it in the counting frame (`Counted`).
    pub(crate) counted: Option<Box<Counted>>,
    pub name: String,
    /// What it was made with, for the port sheets.
    pub(crate) info: Arc<PipelineInfo>,
}

/// The port sheets' copy of `uses`.
fn use_infos(uses: &[BindingUse]) -> Vec<UseInfo> {
    uses.iter()
        .map(|u| UseInfo {
            set: u.set,
            binding: u.binding,
            stages: u.stage,
            writes: u.writes,
        })
        .collect()
}

fn stage_info(stage: &'static str, spirv: &[u8]) -> StageInfo {
    StageInfo {
        stage,
        source: crate::shaders::source_of(spirv).map(str::to_string),
    }
}

/// The counting build of a light pipeline: the same state with the shaders' `-DCOUNT_LIGHT`
/// builds (`shaders::light_count_variant`, glsl/common/count.glsl), which add what each
/// invocation reads to a storage buffer at set 1. Made with the pipeline, wherever one of
/// its shaders has such a build and the device can store from those stages
/// (`Context::light_counting`); the recorder binds it, with the pass's count buffer, in the
/// counting frame only (`FrameRunner::run_counting`), so the timed frame never sees it.
pub(crate) struct Counted {
    pub(crate) pipeline: Pipeline,
    /// The set-1 layout the pipeline was made against (a 32-byte stand-in buffer); every
    /// count buffer's set has the same single binding, so it is compatible.
    _layout: DescriptorSet,
    _stand_in: Buffer,
}

impl Counted {
    /// The stand-in set 1 for a pipeline whose own sets are `sets`.
    fn layout(
        ctx: &Context,
        sets: &[&DescriptorSet],
        name: &str,
    ) -> Result<(Buffer, DescriptorSet)> {
        if sets.len() != 1 {
            bail!(
                "{name}: a counted light pipeline has exactly one descriptor set of its own (set 0), so that the count buffer is set 1; it has {}",
                sets.len()
            );
        }
        let buffer = count_buffer(ctx, 32, "light counts (stand-in)")?;
        let set = count_set(ctx, &buffer)?;
        Ok((buffer, set))
    }

    fn graphics(ctx: &Context, d: &GraphicsPipelineDesc<'_>) -> Result<Option<Box<Self>>> {
        let vertex = crate::shaders::light_count_variant(d.vertex);
        let fragment = d.fragment.and_then(crate::shaders::light_count_variant);
        if !ctx.light_counting || (vertex.is_none() && fragment.is_none()) {
            return Ok(None);
        }
        let (stand_in, layout) = Self::layout(ctx, d.sets, d.name)?;
        let sets = [d.sets[0], &layout];
        let name = format!("{} (counting)", d.name);
        let pipeline = Pipeline::graphics(
            ctx,
            &GraphicsPipelineDesc {
                name: &name,
                vertex: vertex.unwrap_or(d.vertex),
                fragment: fragment.or(d.fragment),
                sets: &sets,
                ..*d
            },
        )?;
        Ok(Some(Box::new(Self {
            pipeline,
            _layout: layout,
            _stand_in: stand_in,
        })))
    }

    fn compute(
        ctx: &Context,
        name: &str,
        spirv: &[u8],
        sets: &[&DescriptorSet],
        push_constant_bytes: u32,
    ) -> Result<Option<Box<Self>>> {
        let Some(counting) = crate::shaders::light_count_variant(spirv) else {
            return Ok(None);
        };
        if !ctx.light_counting {
            return Ok(None);
        }
        let (stand_in, layout) = Self::layout(ctx, sets, name)?;
        let sets = [sets[0], &layout];
        let pipeline = Pipeline::compute(
            ctx,
            &format!("{name} (counting)"),
            counting,
            &sets,
            push_constant_bytes,
        )?;
        Ok(Some(Box::new(Self {
            pipeline,
            _layout: layout,
            _stand_in: stand_in,
        })))
    }
}

/// A buffer of light-pass counts: storage written by the shaders, filled by the recorder,
/// read by the host.
pub(crate) fn count_buffer(ctx: &Context, bytes: u64, name: &str) -> Result<Buffer> {
    Buffer::new(
        ctx,
        bytes,
        vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::TRANSFER_DST,
        gpu_allocator::MemoryLocation::GpuToCpu,
        name,
    )
}

/// The set 1 of a counted light pipeline: `buffer` as glsl/common/count.glsl's `LightCounts`.
pub(crate) fn count_set(ctx: &Context, buffer: &Buffer) -> Result<DescriptorSet> {
    DescriptorSet::new(
        ctx,
        &[("LightCounts", Resource::Storage(buffer))],
        "light counts",
    )
}

fn pipeline_layout(
    ctx: &Context,
    sets: &[&DescriptorSet],
    push_bytes: u32,
    name: &str,
) -> Result<vk::PipelineLayout> {
    let set_layouts: Vec<_> = sets.iter().map(|s| s.layout).collect();
    let ranges = [vk::PushConstantRange::default()
        .stage_flags(vk::ShaderStageFlags::ALL_GRAPHICS | vk::ShaderStageFlags::COMPUTE)
        .offset(0)
        .size(push_bytes)];
    let mut info = vk::PipelineLayoutCreateInfo::default().set_layouts(&set_layouts);
    if push_bytes > 0 {
        info = info.push_constant_ranges(&ranges);
    }
    // SAFETY: valid create info referencing live set layouts.
    unsafe { ctx.device().create_pipeline_layout(&info, None) }
        .with_context(|| format!("creating pipeline layout for {name}"))
}

impl Pipeline {
    #[track_caller]
    pub fn graphics(ctx: &Context, d: &GraphicsPipelineDesc<'_>) -> Result<Self> {
        let made_in = std::panic::Location::caller().file();
        // Checked before anything is created, so that nothing leaks on these errors.
        let ors = d.colors.iter().filter(|c| c.1 == Blend::Or).count();
        if ors > 0 && ors < d.colors.len() {
            bail!(
                "{}: Blend::Or is the pipeline's logic op, so it must be every attachment's blend",
                d.name
            );
        }
        if ors > 0 && !ctx.logic_op {
            bail!(
                "{}: {} lacks the logicOp feature, which OR-combining attachments needs",
                d.name,
                ctx.device_name
            );
        }
        let device = ctx.device();
        let layout = pipeline_layout(ctx, d.sets, d.push_constant_bytes, d.name)?;
        let mut uses = Vec::new();
        let made = shader_module(
            ctx,
            d.vertex,
            &format!("{} (vertex)", d.name),
            d.sets,
            &mut uses,
        )
        .and_then(|vs| match d.fragment {
            Some(f) => {
                match shader_module(ctx, f, &format!("{} (fragment)", d.name), d.sets, &mut uses) {
                    Ok(fs) => Ok((vs, Some(fs))),
                    Err(e) => {
                        // SAFETY: the module is unused.
                        unsafe { device.destroy_shader_module(vs, None) };
                        Err(e)
                    }
                }
            }
            None => Ok((vs, None)),
        });
        let (vs, fs) = match made {
            Ok(m) => m,
            Err(e) => {
                // SAFETY: unused layout.
                unsafe { device.destroy_pipeline_layout(layout, None) };
                return Err(e);
            }
        };
        let mut stages = vec![vk::PipelineShaderStageCreateInfo::default()
            .stage(vk::ShaderStageFlags::VERTEX)
            .module(vs)
            .name(c"main")];
        if let Some(fs) = fs {
            stages.push(
                vk::PipelineShaderStageCreateInfo::default()
                    .stage(vk::ShaderStageFlags::FRAGMENT)
                    .module(fs)
                    .name(c"main"),
            );
        }
        let binding = [vk::VertexInputBindingDescription::default()
            .binding(0)
            .stride(d.vertex_stride)
            .input_rate(vk::VertexInputRate::VERTEX)];
        let attributes: Vec<_> = d
            .attributes
            .iter()
            .map(|&(location, format, offset)| {
                vk::VertexInputAttributeDescription::default()
                    .location(location)
                    .binding(0)
                    .format(format)
                    .offset(offset)
            })
            .collect();
        let mut vertex_input = vk::PipelineVertexInputStateCreateInfo::default();
        if d.vertex_stride > 0 {
            vertex_input = vertex_input
                .vertex_binding_descriptions(&binding)
                .vertex_attribute_descriptions(&attributes);
        }
        let assembly = vk::PipelineInputAssemblyStateCreateInfo::default().topology(d.topology);
        let viewport = vk::PipelineViewportStateCreateInfo::default()
            .viewport_count(1)
            .scissor_count(1);
        let raster = vk::PipelineRasterizationStateCreateInfo::default()
            .polygon_mode(vk::PolygonMode::FILL)
            .cull_mode(d.cull)
            .front_face(vk::FrontFace::COUNTER_CLOCKWISE)
            .line_width(1.0);
        let multisample = vk::PipelineMultisampleStateCreateInfo::default()
            .rasterization_samples(vk::SampleCountFlags::TYPE_1);
        let blend_attachments: Vec<_> = d
            .colors
            .iter()
            .map(|&(_, blend)| {
                let a = vk::PipelineColorBlendAttachmentState::default()
                    .color_write_mask(vk::ColorComponentFlags::RGBA);
                let op = match blend {
                    Blend::None | Blend::Or => return a,
                    Blend::Min => vk::BlendOp::MIN,
                    Blend::Max => vk::BlendOp::MAX,
                    Blend::Add => vk::BlendOp::ADD,
                };
                // MIN/MAX ignore the factors; ADD accumulates src + dst.
                a.blend_enable(true)
                    .color_blend_op(op)
                    .alpha_blend_op(op)
                    .src_color_blend_factor(vk::BlendFactor::ONE)
                    .dst_color_blend_factor(vk::BlendFactor::ONE)
                    .src_alpha_blend_factor(vk::BlendFactor::ONE)
                    .dst_alpha_blend_factor(vk::BlendFactor::ONE)
            })
            .collect();
        let blend = vk::PipelineColorBlendStateCreateInfo::default()
            .logic_op_enable(ors > 0)
            .logic_op(vk::LogicOp::OR)
            .attachments(&blend_attachments);
        let front_face = raster.front_face;
        let depth = match d.depth {
            Some(ds) => vk::PipelineDepthStencilStateCreateInfo::default()
                .depth_test_enable(ds.test)
                .depth_write_enable(ds.write)
                .depth_compare_op(ds.compare),
            None => vk::PipelineDepthStencilStateCreateInfo::default(),
        };
        let dynamic_states = [vk::DynamicState::VIEWPORT, vk::DynamicState::SCISSOR];
        let dynamic = vk::PipelineDynamicStateCreateInfo::default().dynamic_states(&dynamic_states);
        let color_formats: Vec<_> = d.colors.iter().map(|c| c.0).collect();
        let mut rendering = vk::PipelineRenderingCreateInfo::default()
            .color_attachment_formats(&color_formats)
            .depth_attachment_format(d.depth.map(|ds| ds.format).unwrap_or(vk::Format::UNDEFINED));
        let info = vk::GraphicsPipelineCreateInfo::default()
            .stages(&stages)
            .vertex_input_state(&vertex_input)
            .input_assembly_state(&assembly)
            .viewport_state(&viewport)
            .rasterization_state(&raster)
            .multisample_state(&multisample)
            .color_blend_state(&blend)
            .depth_stencil_state(&depth)
            .dynamic_state(&dynamic)
            .layout(layout)
            .push_next(&mut rendering);
        // SAFETY: every state struct above lives until the call returns.
        let result =
            unsafe { device.create_graphics_pipelines(vk::PipelineCache::null(), &[info], None) };
        // SAFETY: modules are no longer needed once the pipeline exists (or failed).
        unsafe {
            device.destroy_shader_module(vs, None);
            if let Some(fs) = fs {
                device.destroy_shader_module(fs, None);
            }
        }
        let raw = match result {
            Ok(p) => p[0],
            Err((_, e)) => {
                // SAFETY: unused layout.
                unsafe { device.destroy_pipeline_layout(layout, None) };
                return Err(e).with_context(|| format!("creating pipeline {}", d.name));
            }
        };
        let mut stages = vec![stage_info("vertex", d.vertex)];
        stages.extend(d.fragment.map(|f| stage_info("fragment", f)));
        let info = PipelineInfo {
            name: d.name.to_string(),
            compute: false,
            stages,
            vertex_stride: d.vertex_stride,
            attributes: match d.vertex_stride {
                0 => Vec::new(),
                _ => d.attributes.to_vec(),
            },
            topology: d.topology,
            cull: d.cull,
            front_face,
            colors: d
                .colors
                .iter()
                .zip(&blend_attachments)
                .map(|(&(format, _), a)| BlendInfo {
                    format,
                    enable: a.blend_enable != vk::FALSE,
                    color_op: a.color_blend_op,
                    alpha_op: a.alpha_blend_op,
                    src_factor: a.src_color_blend_factor,
                    dst_factor: a.dst_color_blend_factor,
                    write_mask: a.color_write_mask,
                })
                .collect(),
            logic_op: (ors > 0).then_some(vk::LogicOp::OR),
            depth: d.depth.map(|ds| DepthInfo {
                format: ds.format,
                test: ds.test,
                write: ds.write,
                compare: ds.compare,
            }),
            push_constant_bytes: d.push_constant_bytes,
            sets: d.sets.iter().map(|s| s.name.clone()).collect(),
            uses: use_infos(&uses),
            made_in,
        };
        let mut this = Self {
            shared: ctx.shared.clone(),
            raw,
            layout,
            bind_point: vk::PipelineBindPoint::GRAPHICS,
            uses: uses.into(),
            vertex_input: d.vertex_stride > 0,
            counted: None,
            name: d.name.to_string(),
            info: Arc::new(info),
        };
        this.counted = Counted::graphics(ctx, d)?;
        Ok(this)
    }

    #[track_caller]
    pub fn compute(
        ctx: &Context,
        name: &str,
        spirv: &[u8],
        sets: &[&DescriptorSet],
        push_constant_bytes: u32,
    ) -> Result<Self> {
        let made_in = std::panic::Location::caller().file();
        let device = ctx.device();
        let layout = pipeline_layout(ctx, sets, push_constant_bytes, name)?;
        let mut uses = Vec::new();
        let module = match shader_module(ctx, spirv, name, sets, &mut uses) {
            Ok(m) => m,
            Err(e) => {
                // SAFETY: unused layout.
                unsafe { device.destroy_pipeline_layout(layout, None) };
                return Err(e);
            }
        };
        let stage = vk::PipelineShaderStageCreateInfo::default()
            .stage(vk::ShaderStageFlags::COMPUTE)
            .module(module)
            .name(c"main");
        let info = vk::ComputePipelineCreateInfo::default()
            .stage(stage)
            .layout(layout);
        // SAFETY: valid create info.
        let result =
            unsafe { device.create_compute_pipelines(vk::PipelineCache::null(), &[info], None) };
        // SAFETY: the module is not needed after creation.
        unsafe { device.destroy_shader_module(module, None) };
        let raw = match result {
            Ok(p) => p[0],
            Err((_, e)) => {
                // SAFETY: unused layout.
                unsafe { device.destroy_pipeline_layout(layout, None) };
                return Err(e).with_context(|| format!("creating compute pipeline {name}"));
            }
        };
        let info = PipelineInfo {
            name: name.to_string(),
            compute: true,
            stages: vec![stage_info("compute", spirv)],
            vertex_stride: 0,
            attributes: Vec::new(),
            topology: vk::PrimitiveTopology::default(),
            cull: vk::CullModeFlags::NONE,
            front_face: vk::FrontFace::default(),
            colors: Vec::new(),
            logic_op: None,
            depth: None,
            push_constant_bytes,
            sets: sets.iter().map(|s| s.name.clone()).collect(),
            uses: use_infos(&uses),
            made_in,
        };
        let mut this = Self {
            shared: ctx.shared.clone(),
            raw,
            layout,
            bind_point: vk::PipelineBindPoint::COMPUTE,
            uses: uses.into(),
            vertex_input: false,
            counted: None,
            name: name.to_string(),
            info: Arc::new(info),
        };
        this.counted = Counted::compute(ctx, name, spirv, sets, push_constant_bytes)?;
        Ok(this)
    }
}

impl Drop for Pipeline {
    fn drop(&mut self) {
        // SAFETY: no pending command buffer uses the pipeline.
        unsafe {
            self.shared.device.destroy_pipeline(self.raw, None);
            self.shared
                .device
                .destroy_pipeline_layout(self.layout, None);
        }
    }
}
