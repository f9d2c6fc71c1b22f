//! Buffers, images and samplers, each owning its Vulkan handle and its gpu-allocator
//! allocation and freeing both in `Drop`.

use super::context::{Context, Shared};
use super::sync::{Target, Tracked};
use anyhow::{bail, Context as _, Result};
use ash::vk;
use gpu_allocator::vulkan::{Allocation, AllocationCreateDesc, AllocationScheme};
use gpu_allocator::MemoryLocation;
use std::sync::Arc;

pub struct Buffer {
    shared: Arc<Shared>,
    pub(crate) raw: vk::Buffer,
    allocation: Option<Allocation>,
    pub size: u64,
    sync: Arc<Tracked>,
    /// The name it was made with: barriers and port sheets name it by this.
    pub name: String,
}

impl Buffer {
    /// An uninitialised buffer in `location` (GpuOnly, CpuToGpu for uploads/uniforms,
    /// GpuToCpu for readback).
    pub fn new(
        ctx: &Context,
        size: u64,
        usage: vk::BufferUsageFlags,
        location: MemoryLocation,
        name: &str,
    ) -> Result<Self> {
        let device = ctx.device();
        let size = size.max(4);
        let info = vk::BufferCreateInfo::default()
            .size(size)
            .usage(usage)
            .sharing_mode(vk::SharingMode::EXCLUSIVE);
        // SAFETY: valid create info; the buffer is destroyed in Drop.
        let raw = unsafe { device.create_buffer(&info, None) }
            .with_context(|| format!("creating buffer '{name}' ({size} bytes)"))?;
        // SAFETY: `raw` was just created on this device.
        let requirements = unsafe { device.get_buffer_memory_requirements(raw) };
        let allocation = ctx
            .shared
            .allocator
            .lock()
            .map_err(|_| anyhow::anyhow!("allocator lock poisoned"))?
            .allocate(&AllocationCreateDesc {
                name,
                requirements,
                location,
                linear: true,
                allocation_scheme: AllocationScheme::GpuAllocatorManaged,
            });
        let allocation = match allocation {
            Ok(a) => a,
            Err(e) => {
                // SAFETY: not bound, not in use.
                unsafe { device.destroy_buffer(raw, None) };
                return Err(e)
                    .with_context(|| format!("allocating buffer '{name}' ({size} bytes)"));
            }
        };
        // SAFETY: memory and offset come from the allocator for these requirements.
        unsafe { device.bind_buffer_memory(raw, allocation.memory(), allocation.offset()) }
            .with_context(|| format!("binding memory of buffer '{name}'"))?;
        Ok(Self {
            shared: ctx.shared.clone(),
            raw,
            allocation: Some(allocation),
            size,
            sync: Tracked::new(),
            name: name.to_string(),
        })
    }

    /// Host-visible buffer filled with `data`: CpuToGpu is device-local and mapped where the
    /// device has such memory (resizable BAR, CPU drivers), so small per-frame uploads cost
    /// no copy pass.
    pub fn with_data(
        ctx: &Context,
        data: &[u8],
        usage: vk::BufferUsageFlags,
        name: &str,
    ) -> Result<Self> {
        let mut b = Self::new(
            ctx,
            data.len() as u64,
            usage,
            MemoryLocation::CpuToGpu,
            name,
        )?;
        b.write(0, data)?;
        Ok(b)
    }

    /// Copies `data` into a mapped buffer at byte `offset`.
    pub fn write(&mut self, offset: u64, data: &[u8]) -> Result<()> {
        let Some(alloc) = self.allocation.as_mut() else {
            bail!("buffer has no memory")
        };
        let Some(slice) = alloc.mapped_slice_mut() else {
            bail!("buffer is not host visible")
        };
        let start = offset as usize;
        let end = start + data.len();
        if end > slice.len() {
            bail!(
                "write of {} bytes at {offset} overflows a {}-byte buffer",
                data.len(),
                slice.len()
            );
        }
        slice[start..end].copy_from_slice(data);
        Ok(())
    }

    /// The buffer as barriers name it.
    pub(crate) fn target(&self) -> Target {
        Target::Buffer {
            raw: self.raw,
            sync: self.sync.clone(),
            name: self.name.clone(),
        }
    }

    /// The mapped bytes of a host-visible buffer (readback after the GPU finished).
    pub fn read(&self) -> Result<&[u8]> {
        self.allocation
            .as_ref()
            .and_then(|a| a.mapped_slice())
            .ok_or_else(|| anyhow::anyhow!("buffer is not host visible"))
    }
}

impl Drop for Buffer {
    fn drop(&mut self) {
        // SAFETY: the owner guarantees the GPU no longer uses the buffer (frames wait on
        // their fence before resources drop); the allocation is freed after the handle.
        unsafe { self.shared.device.destroy_buffer(self.raw, None) };
        if let Some(a) = self.allocation.take() {
            if let Ok(mut alloc) = self.shared.allocator.lock() {
                let _ = alloc.free(a);
            }
        }
    }
}

/// A 1-D or 2-D image with one view. Its layout and last accesses are tracked with it, so
/// that the `Recorder` derives every barrier and layout transition it needs.
pub struct Image {
    shared: Arc<Shared>,
    pub(crate) raw: vk::Image,
    pub(crate) view: vk::ImageView,
    allocation: Option<Allocation>,
    pub format: vk::Format,
    pub extent: vk::Extent2D,
    pub(crate) aspect: vk::ImageAspectFlags,
    sync: Arc<Tracked>,
    pub name: String,
}

impl Image {
    pub fn new_2d(
        ctx: &Context,
        width: u32,
        height: u32,
        format: vk::Format,
        usage: vk::ImageUsageFlags,
        name: &str,
    ) -> Result<Self> {
        Self::create(
            ctx,
            vk::ImageType::TYPE_2D,
            width,
            height,
            format,
            usage,
            name,
        )
    }

    pub fn new_1d(
        ctx: &Context,
        width: u32,
        format: vk::Format,
        usage: vk::ImageUsageFlags,
        name: &str,
    ) -> Result<Self> {
        Self::create(ctx, vk::ImageType::TYPE_1D, width, 1, format, usage, name)
    }

    fn create(
        ctx: &Context,
        ty: vk::ImageType,
        width: u32,
        height: u32,
        format: vk::Format,
        usage: vk::ImageUsageFlags,
        name: &str,
    ) -> Result<Self> {
        let max = ctx.limits.max_image_dimension2_d;
        if width == 0 || height == 0 || width > max || height > max {
            bail!(
                "image '{name}' is {width}x{height}: each side must be in 1..={max} on this device"
            );
        }
        let device = ctx.device();
        let depth = matches!(
            format,
            vk::Format::D32_SFLOAT | vk::Format::D16_UNORM | vk::Format::D24_UNORM_S8_UINT
        );
        let aspect = if depth {
            vk::ImageAspectFlags::DEPTH
        } else {
            vk::ImageAspectFlags::COLOR
        };
        let info = vk::ImageCreateInfo::default()
            .image_type(ty)
            .format(format)
            .extent(vk::Extent3D {
                width,
                height,
                depth: 1,
            })
            .mip_levels(1)
            .array_layers(1)
            .samples(vk::SampleCountFlags::TYPE_1)
            .tiling(vk::ImageTiling::OPTIMAL)
            .usage(usage)
            .sharing_mode(vk::SharingMode::EXCLUSIVE)
            .initial_layout(vk::ImageLayout::UNDEFINED);
        // SAFETY: valid create info; destroyed in Drop.
        let raw = unsafe { device.create_image(&info, None) }
            .with_context(|| format!("creating image '{name}' {width}x{height} {format:?}"))?;
        // SAFETY: `raw` was just created on this device.
        let requirements = unsafe { device.get_image_memory_requirements(raw) };
        let allocation = ctx
            .shared
            .allocator
            .lock()
            .map_err(|_| anyhow::anyhow!("allocator lock poisoned"))?
            .allocate(&AllocationCreateDesc {
                name,
                requirements,
                location: MemoryLocation::GpuOnly,
                linear: false,
                allocation_scheme: AllocationScheme::GpuAllocatorManaged,
            });
        let allocation = match allocation {
            Ok(a) => a,
            Err(e) => {
                // SAFETY: not bound, not in use.
                unsafe { device.destroy_image(raw, None) };
                return Err(e).with_context(|| format!("allocating image '{name}'"));
            }
        };
        // SAFETY: memory from the allocator for these requirements.
        unsafe { device.bind_image_memory(raw, allocation.memory(), allocation.offset()) }
            .with_context(|| format!("binding memory of image '{name}'"))?;
        let view_type = if ty == vk::ImageType::TYPE_1D {
            vk::ImageViewType::TYPE_1D
        } else {
            vk::ImageViewType::TYPE_2D
        };
        let view_info = vk::ImageViewCreateInfo::default()
            .image(raw)
            .view_type(view_type)
            .format(format)
            .subresource_range(subresource(aspect));
        // SAFETY: the image is bound to memory; the view is destroyed before it in Drop.
        let view = match unsafe { device.create_image_view(&view_info, None) } {
            Ok(v) => v,
            Err(e) => {
                // SAFETY: not in use.
                unsafe { device.destroy_image(raw, None) };
                if let Ok(mut a) = ctx.shared.allocator.lock() {
                    let _ = a.free(allocation);
                }
                return Err(e).with_context(|| format!("creating view of image '{name}'"));
            }
        };
        Ok(Self {
            shared: ctx.shared.clone(),
            raw,
            view,
            allocation: Some(allocation),
            format,
            extent: vk::Extent2D { width, height },
            aspect,
            sync: Tracked::new(),
            name: name.to_string(),
        })
    }

    /// The image as barriers name it.
    pub(crate) fn target(&self) -> Target {
        Target::Image {
            raw: self.raw,
            aspect: self.aspect,
            sync: self.sync.clone(),
            name: self.name.clone(),
        }
    }

    /// Bytes per texel of the formats this crate reads back.
    pub fn texel_size(&self) -> u64 {
        match self.format {
            vk::Format::R8G8B8A8_UNORM | vk::Format::R32_SFLOAT | vk::Format::D32_SFLOAT => 4,
            vk::Format::R16_SFLOAT => 2,
            vk::Format::R16G16B16A16_SFLOAT | vk::Format::R32G32_SFLOAT => 8,
            vk::Format::R16G16_SFLOAT => 4,
            vk::Format::R32G32B32A32_SFLOAT | vk::Format::R32G32B32A32_UINT => 16,
            _ => 4,
        }
    }
}

pub(crate) fn subresource(aspect: vk::ImageAspectFlags) -> vk::ImageSubresourceRange {
    vk::ImageSubresourceRange::default()
        .aspect_mask(aspect)
        .base_mip_level(0)
        .level_count(1)
        .base_array_layer(0)
        .layer_count(1)
}

impl Drop for Image {
    fn drop(&mut self) {
        // SAFETY: the GPU is done with the image (frames wait on their fence); the view goes
        // before the image, the memory after both.
        unsafe {
            self.shared.device.destroy_image_view(self.view, None);
            self.shared.device.destroy_image(self.raw, None);
        }
        if let Some(a) = self.allocation.take() {
            if let Ok(mut alloc) = self.shared.allocator.lock() {
                let _ = alloc.free(a);
            }
        }
    }
}

/// Filtering of a sampler.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Filter {
    Nearest,
    Linear,
}

pub struct Sampler {
    shared: Arc<Shared>,
    pub(crate) raw: vk::Sampler,
    /// Filter, addressing and comparison, as a port sheet shows them.
    pub(crate) description: String,
}

impl Sampler {
    /// Clamp-to-edge sampler, no mipmaps.
    pub fn new(ctx: &Context, filter: Filter) -> Result<Self> {
        Self::create(ctx, filter, None)
    }

    /// Clamp-to-edge depth-comparison sampler (`sampler2DShadow`), bilinear: each of the 2x2
    /// texels is compared as `reference OP texel` and the four 0/1 results are weighted
    /// bilinearly (the hardware "percentage closer" filter).
    pub fn compare(ctx: &Context, op: vk::CompareOp) -> Result<Self> {
        Self::create(ctx, Filter::Linear, Some(op))
    }

    fn create(ctx: &Context, filter: Filter, compare: Option<vk::CompareOp>) -> Result<Self> {
        let f = match filter {
            Filter::Nearest => vk::Filter::NEAREST,
            Filter::Linear => vk::Filter::LINEAR,
        };
        let mut info = vk::SamplerCreateInfo::default()
            .mag_filter(f)
            .min_filter(f)
            .mipmap_mode(vk::SamplerMipmapMode::NEAREST)
            .address_mode_u(vk::SamplerAddressMode::CLAMP_TO_EDGE)
            .address_mode_v(vk::SamplerAddressMode::CLAMP_TO_EDGE)
            .address_mode_w(vk::SamplerAddressMode::CLAMP_TO_EDGE)
            // Every image has one level; an LOD clamp would only cost (Arm's best practices).
            .max_lod(vk::LOD_CLAMP_NONE);
        if let Some(op) = compare {
            info = info.compare_enable(true).compare_op(op);
        }
        // SAFETY: valid create info; destroyed in Drop.
        let raw =
            unsafe { ctx.device().create_sampler(&info, None) }.context("creating sampler")?;
        let compare = match compare {
            Some(op) => format!(", compare {op:?}"),
            None => String::new(),
        };
        Ok(Self {
            shared: ctx.shared.clone(),
            raw,
            description: format!("{f:?}, clamp to edge{compare}"),
        })
    }
}

impl Drop for Sampler {
    fn drop(&mut self) {
        // SAFETY: no command buffer using the sampler is pending.
        unsafe { self.shared.device.destroy_sampler(self.raw, None) };
    }
}
