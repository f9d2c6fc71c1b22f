//! Instance, physical-device pick, logical device, one graphics+compute queue, the
//! gpu-allocator, and the validation-layer messenger. Headless: no surface, no swapchain.

use super::pipeline::Blend;
use anyhow::{anyhow, bail, Context as _, Result};
use ash::vk;
use gpu_allocator::vulkan::{Allocator, AllocatorCreateDesc};
use std::ffi::{c_void, CStr, CString};
use std::mem::ManuallyDrop;
use std::sync::{Arc, Mutex};

const VALIDATION_LAYER: &CStr = c"VK_LAYER_KHRONOS_validation";

/// How to open the device.
#[derive(Clone, Debug, Default)]
pub struct ContextOptions {
    /// Case-insensitive substring of the device name; `None` picks a real GPU, else lavapipe.
    pub device: Option<String>,
    /// Enable VK_LAYER_KHRONOS_validation, with its synchronization validation, and route
    /// its messages through a debug messenger. `SOFTSHADOW_BEST_PRACTICES=1` in the
    /// environment adds the layer's best-practices checks.
    pub validation: bool,
}

impl ContextOptions {
    /// Options from the environment: `SOFTSHADOW_DEVICE` picks the device,
    /// `SOFTSHADOW_VALIDATION=1` turns validation on.
    pub fn from_env() -> Self {
        Self {
            device: std::env::var("SOFTSHADOW_DEVICE")
                .ok()
                .filter(|s| !s.is_empty()),
            validation: std::env::var("SOFTSHADOW_VALIDATION").is_ok_and(|v| v != "0"),
        }
    }
}

/// Messages the validation layer reported (warnings and errors), per context.
#[derive(Default)]
pub struct ValidationLog {
    messages: Mutex<Vec<String>>,
}

impl ValidationLog {
    pub fn messages(&self) -> Vec<String> {
        self.messages.lock().map(|m| m.clone()).unwrap_or_default()
    }
    fn push(&self, msg: String) {
        if let Ok(mut m) = self.messages.lock() {
            m.push(msg);
        }
    }
}

/// Owns everything with a device lifetime. Wrappers hold an `Arc<Shared>`, so the device
/// outlives every object made from it; `Drop` frees the allocator before the device and
/// the device before the instance.
pub struct Shared {
    pub(crate) allocator: ManuallyDrop<Mutex<Allocator>>,
    pub(crate) device: ash::Device,
    pub(crate) debug_utils: Option<ash::ext::debug_utils::Device>,
    messenger: Option<(ash::ext::debug_utils::Instance, vk::DebugUtilsMessengerEXT)>,
    // Boxed so the messenger's user-data pointer stays valid while `Shared` moves.
    log: Box<ValidationLog>,
    instance: ash::Instance,
    _entry: ash::Entry,
}

impl Shared {
    pub(crate) fn instance_ref(&self) -> &ash::Instance {
        &self.instance
    }
}

impl Drop for Shared {
    fn drop(&mut self) {
        // SAFETY: every wrapper holding an Arc<Shared> is gone (this is the last
        // reference), so no object made from the device is alive; the allocator goes first
        // because it frees device memory, then the device, the messenger and the instance.
        unsafe {
            let _ = self.device.device_wait_idle();
            ManuallyDrop::drop(&mut self.allocator);
            self.device.destroy_device(None);
            if let Some((loader, messenger)) = self.messenger.take() {
                loader.destroy_debug_utils_messenger(messenger, None);
            }
            self.instance.destroy_instance(None);
        }
    }
}

/// The opened device with its queue. Cheap to share by reference; objects made from it
/// keep the device alive through `Arc<Shared>`.
pub struct Context {
    pub(crate) shared: Arc<Shared>,
    pub(crate) physical: vk::PhysicalDevice,
    pub(crate) queue: vk::Queue,
    pub(crate) queue_family: u32,
    pub limits: vk::PhysicalDeviceLimits,
    pub device_name: String,
    pub device_type: vk::PhysicalDeviceType,
    pub driver_name: String,
    pub driver_info: String,
    pub validation: bool,
    /// Whether the `logicOp` feature is enabled (enabled wherever the device offers it):
    /// `Blend::Or` pipelines need it.
    pub logic_op: bool,
    /// Whether the `largePoints` feature is enabled (wherever offered): without it a point
    /// is one pixel, and `ssm-bitmask` draws every micro-quad as triangles.
    pub large_points: bool,
    /// Whether the `pipelineStatisticsQuery` feature is enabled (wherever the device offers
    /// it): the per-pass work counts of `--timings` and the bench need it, and are left
    /// empty without it.
    pub pipeline_statistics: bool,
    /// Whether the `independentBlend` feature is enabled (wherever offered): the counting
    /// pass (colour overwritten, counts added) needs it, and is not built without it.
    pub independent_blend: bool,
    /// Whether `fragmentStoresAndAtomics` and `vertexPipelineStoresAndAtomics` are enabled
    /// (wherever offered): the counting builds of light passes need them, and light passes
    /// are not counted without them.
    pub light_counting: bool,
}

unsafe extern "system" fn debug_callback(
    severity: vk::DebugUtilsMessageSeverityFlagsEXT,
    _types: vk::DebugUtilsMessageTypeFlagsEXT,
    data: *const vk::DebugUtilsMessengerCallbackDataEXT<'_>,
    user: *mut c_void,
) -> vk::Bool32 {
    // SAFETY: the layer passes a valid callback-data pointer for the duration of the call,
    // and `user` is the boxed ValidationLog owned by `Shared`, alive while the messenger is.
    unsafe {
        if data.is_null() || user.is_null() {
            return vk::FALSE;
        }
        let msg = (*data)
            .message_as_c_str()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default();
        let line = format!("validation {severity:?}: {msg}");
        eprintln!("{line}");
        (*(user as *const ValidationLog)).push(line);
    }
    vk::FALSE
}

impl Context {
    pub fn new(opts: &ContextOptions) -> Result<Self> {
        // SAFETY: loading the Vulkan loader library; ash checks the symbols it resolves.
        let entry = unsafe { ash::Entry::load() }.map_err(|e| {
            anyhow!("no Vulkan loader ({e}): install the Debian packages libvulkan1 and mesa-vulkan-drivers")
        })?;

        let mut layers: Vec<*const i8> = Vec::new();
        let mut extensions: Vec<*const i8> = Vec::new();
        if opts.validation {
            // SAFETY: plain enumeration on a loaded entry.
            let available = unsafe { entry.enumerate_instance_layer_properties() }
                .context("enumerating Vulkan layers")?;
            let found = available
                .iter()
                .any(|l| l.layer_name_as_c_str().is_ok_and(|n| n == VALIDATION_LAYER));
            if !found {
                bail!("validation was asked for but VK_LAYER_KHRONOS_validation is missing: install the Debian package vulkan-validationlayers");
            }
            // SAFETY: plain enumeration on a loaded entry.
            let layer_extensions =
                unsafe { entry.enumerate_instance_extension_properties(Some(VALIDATION_LAYER)) }
                    .context("enumerating the validation layer's extensions")?;
            let features = layer_extensions.iter().any(|e| {
                e.extension_name_as_c_str()
                    .is_ok_and(|n| n == ash::ext::validation_features::NAME)
            });
            if !features {
                bail!("the installed VK_LAYER_KHRONOS_validation lacks VK_EXT_validation_features, which synchronization validation needs: install a newer vulkan-validationlayers");
            }
            layers.push(VALIDATION_LAYER.as_ptr());
            extensions.push(ash::ext::debug_utils::NAME.as_ptr());
            extensions.push(ash::ext::validation_features::NAME.as_ptr());
        } else if instance_has_extension(&entry, ash::ext::debug_utils::NAME) {
            // Debug labels (pass names) for capture tools, when the loader offers them.
            extensions.push(ash::ext::debug_utils::NAME.as_ptr());
        }
        let debug_utils_on = !extensions.is_empty();

        let app_name = CString::new("softshadow").context("app name")?;
        let app = vk::ApplicationInfo::default()
            .application_name(&app_name)
            .application_version(1)
            .engine_name(&app_name)
            .api_version(vk::API_VERSION_1_3);
        let mut log = Box::new(ValidationLog::default());
        let mut messenger_info = vk::DebugUtilsMessengerCreateInfoEXT::default()
            .message_severity(
                vk::DebugUtilsMessageSeverityFlagsEXT::WARNING
                    | vk::DebugUtilsMessageSeverityFlagsEXT::ERROR,
            )
            // GENERAL is the loader's chatter (e.g. "Found no drivers!" before our own,
            // clearer error); validation and performance messages are the layer's findings.
            .message_type(
                vk::DebugUtilsMessageTypeFlagsEXT::VALIDATION
                    | vk::DebugUtilsMessageTypeFlagsEXT::PERFORMANCE,
            )
            .pfn_user_callback(Some(debug_callback))
            .user_data(&mut *log as *mut ValidationLog as *mut c_void);
        // Synchronization validation finds missing barriers, which the rest of the layer
        // does not look for.
        let mut enables = vec![vk::ValidationFeatureEnableEXT::SYNCHRONIZATION_VALIDATION];
        if std::env::var("SOFTSHADOW_BEST_PRACTICES").is_ok_and(|v| !v.is_empty() && v != "0") {
            enables.push(vk::ValidationFeatureEnableEXT::BEST_PRACTICES);
        }
        let mut validation_features =
            vk::ValidationFeaturesEXT::default().enabled_validation_features(&enables);
        let mut create = vk::InstanceCreateInfo::default()
            .application_info(&app)
            .enabled_layer_names(&layers)
            .enabled_extension_names(&extensions);
        if opts.validation {
            // Also catches messages from vkCreateInstance/vkDestroyInstance themselves.
            create = create
                .push_next(&mut messenger_info)
                .push_next(&mut validation_features);
        }
        // SAFETY: all pointers in `create` reference locals that outlive the call.
        let instance = unsafe { entry.create_instance(&create, None) }.map_err(instance_error)?;

        let messenger = if opts.validation {
            let loader = ash::ext::debug_utils::Instance::new(&entry, &instance);
            // SAFETY: the instance is valid and the callback/user data outlive the messenger.
            let m = unsafe { loader.create_debug_utils_messenger(&messenger_info, None) }
                .context("creating the debug messenger")?;
            Some((loader, m))
        } else {
            None
        };

        let picked = pick_physical_device(&instance, opts.device.as_deref());
        let (physical, queue_family) = match picked {
            Ok(p) => p,
            Err(e) => {
                // SAFETY: nothing else was created from the instance besides the messenger.
                unsafe {
                    if let Some((loader, m)) = &messenger {
                        loader.destroy_debug_utils_messenger(*m, None);
                    }
                    instance.destroy_instance(None);
                }
                return Err(e);
            }
        };

        // SAFETY: `physical` came from this instance.
        let props = unsafe { instance.get_physical_device_properties(physical) };
        let mut driver = vk::PhysicalDeviceDriverProperties::default();
        let mut props2 = vk::PhysicalDeviceProperties2::default().push_next(&mut driver);
        // SAFETY: as above; the chain points at a local.
        unsafe { instance.get_physical_device_properties2(physical, &mut props2) };
        let device_name = props
            .device_name_as_c_str()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default();
        let driver_name = driver
            .driver_name_as_c_str()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default();
        let driver_info = driver
            .driver_info_as_c_str()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default();

        let priorities = [1.0f32];
        let queue_info = [vk::DeviceQueueCreateInfo::default()
            .queue_family_index(queue_family)
            .queue_priorities(&priorities)];
        let mut f13 = vk::PhysicalDeviceVulkan13Features::default()
            .dynamic_rendering(true)
            .synchronization2(true)
            // Required by Vulkan 1.3; spirv-opt emits LocalSizeId for compute shaders.
            .maintenance4(true);
        let mut f12 = vk::PhysicalDeviceVulkan12Features::default().host_query_reset(true);
        // SAFETY: `physical` belongs to this instance.
        let offered = unsafe { instance.get_physical_device_features(physical) };
        // Optional: only the techniques that OR integer attachments need it (they say so
        // when it is missing), so a device without it still runs the others.
        let logic_op = offered.logic_op == vk::TRUE;
        // Optional: the per-pass counters beside the timestamps; without it they are empty.
        let pipeline_statistics = offered.pipeline_statistics_query == vk::TRUE;
        let independent_blend = offered.independent_blend == vk::TRUE;
        let large_points = offered.large_points == vk::TRUE;
        // Optional: the counting builds of light passes add to a storage buffer from the
        // vertex, fragment and compute stages; without them those passes are not counted.
        let light_counting = offered.fragment_stores_and_atomics == vk::TRUE
            && offered.vertex_pipeline_stores_and_atomics == vk::TRUE;
        let features = vk::PhysicalDeviceFeatures::default()
            .logic_op(logic_op)
            .independent_blend(independent_blend)
            .large_points(large_points)
            .pipeline_statistics_query(pipeline_statistics)
            .fragment_stores_and_atomics(light_counting)
            .vertex_pipeline_stores_and_atomics(light_counting);
        let device_create = vk::DeviceCreateInfo::default()
            .queue_create_infos(&queue_info)
            .enabled_features(&features)
            .push_next(&mut f13)
            .push_next(&mut f12);
        // SAFETY: `physical` and `queue_family` were validated by pick_physical_device.
        let device = unsafe { instance.create_device(physical, &device_create, None) }
            .with_context(|| format!("creating the logical device on {device_name}"))?;
        // SAFETY: queue 0 of the family we created.
        let queue = unsafe { device.get_device_queue(queue_family, 0) };

        let allocator = Allocator::new(&AllocatorCreateDesc {
            instance: instance.clone(),
            device: device.clone(),
            physical_device: physical,
            debug_settings: Default::default(),
            buffer_device_address: false,
            allocation_sizes: Default::default(),
        })
        .context("creating the GPU memory allocator")?;

        let debug_utils =
            debug_utils_on.then(|| ash::ext::debug_utils::Device::new(&instance, &device));

        let shared = Arc::new(Shared {
            allocator: ManuallyDrop::new(Mutex::new(allocator)),
            device,
            debug_utils,
            messenger,
            // Moving the Box keeps its heap address, which the messenger points at.
            log,
            instance,
            _entry: entry,
        });

        Ok(Self {
            shared,
            physical,
            queue,
            queue_family,
            limits: props.limits,
            device_name,
            device_type: props.device_type,
            driver_name,
            driver_info,
            validation: opts.validation,
            logic_op,
            large_points,
            pipeline_statistics,
            independent_blend,
            light_counting,
        })
    }

    pub(crate) fn device(&self) -> &ash::Device {
        &self.shared.device
    }

    /// One line naming the device and driver, printed by every command.
    pub fn describe(&self) -> String {
        let kind = match self.device_type {
            vk::PhysicalDeviceType::CPU => "CPU",
            vk::PhysicalDeviceType::DISCRETE_GPU => "discrete GPU",
            vk::PhysicalDeviceType::INTEGRATED_GPU => "integrated GPU",
            vk::PhysicalDeviceType::VIRTUAL_GPU => "virtual GPU",
            _ => "other",
        };
        format!(
            "device: {} ({kind}), driver: {} {}",
            self.device_name, self.driver_name, self.driver_info
        )
    }

    /// Validation messages so far (empty when validation is off or all is well).
    pub fn validation_messages(&self) -> Vec<String> {
        self.shared.log.messages()
    }

    /// An error naming the count and the first of the validation messages so far, if any:
    /// a command that met one fails.
    pub fn check_validation(&self) -> anyhow::Result<()> {
        let msgs = self.validation_messages();
        match msgs.first() {
            Some(first) => {
                anyhow::bail!("{} validation message(s), the first: {first}", msgs.len())
            }
            None => Ok(()),
        }
    }

    /// Nanoseconds per timestamp tick.
    pub fn timestamp_period(&self) -> f32 {
        self.limits.timestamp_period
    }

    pub fn wait_idle(&self) -> Result<()> {
        // SAFETY: the device is valid for the life of `self`.
        unsafe { self.device().device_wait_idle() }.context("waiting for the device")
    }

    /// An error naming the device, the blend and `user` (what needs it) unless `format` can
    /// be a colour attachment with blending (`op`: MIN, MAX, ADD).
    pub fn require_blend(&self, format: vk::Format, op: Blend, user: &str) -> Result<()> {
        if !self.supports_blend(format) {
            let op = format!("{op:?}").to_uppercase();
            bail!(
                "{} cannot {op}-blend {format:?} attachments, which {user} needs",
                self.device_name
            );
        }
        Ok(())
    }

    /// Whether `format` can be a colour attachment with blending.
    pub fn supports_blend(&self, format: vk::Format) -> bool {
        // SAFETY: `physical` belongs to this instance.
        let props = unsafe {
            self.shared
                .instance
                .get_physical_device_format_properties(self.physical, format)
        };
        props
            .optimal_tiling_features
            .contains(vk::FormatFeatureFlags::COLOR_ATTACHMENT_BLEND)
    }
}

fn instance_has_extension(entry: &ash::Entry, name: &CStr) -> bool {
    // SAFETY: plain enumeration on a loaded entry.
    unsafe { entry.enumerate_instance_extension_properties(None) }
        .map(|exts| {
            exts.iter()
                .any(|e| e.extension_name_as_c_str().is_ok_and(|n| n == name))
        })
        .unwrap_or(false)
}

/// Whether `pd` offers every feature `Context::new` enables (asked before creating the
/// device, so a device without one is passed over rather than failing to open).
fn has_required_features(instance: &ash::Instance, pd: vk::PhysicalDevice) -> bool {
    let mut f13 = vk::PhysicalDeviceVulkan13Features::default();
    let mut f12 = vk::PhysicalDeviceVulkan12Features::default();
    let mut features = vk::PhysicalDeviceFeatures2::default()
        .push_next(&mut f13)
        .push_next(&mut f12);
    // SAFETY: `pd` came from this instance; the chain points at locals.
    unsafe { instance.get_physical_device_features2(pd, &mut features) };
    f13.dynamic_rendering == vk::TRUE
        && f13.synchronization2 == vk::TRUE
        && f13.maintenance4 == vk::TRUE
        && f12.host_query_reset == vk::TRUE
}

/// A real GPU when there is one, else a CPU device (lavapipe); `filter` picks by name.
fn pick_physical_device(
    instance: &ash::Instance,
    filter: Option<&str>,
) -> Result<(vk::PhysicalDevice, u32)> {
    // SAFETY: enumeration on a valid instance.
    let devices =
        unsafe { instance.enumerate_physical_devices() }.context("enumerating Vulkan devices")?;
    if devices.is_empty() {
        bail!("no Vulkan device found: install the Debian package mesa-vulkan-drivers (lavapipe, a CPU Vulkan driver)");
    }
    let mut candidates = Vec::new();
    let mut names = Vec::new();
    for pd in devices {
        // SAFETY: `pd` came from this instance.
        let props = unsafe { instance.get_physical_device_properties(pd) };
        let name = props
            .device_name_as_c_str()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default();
        names.push(name.clone());
        if let Some(f) = filter {
            if !name.to_lowercase().contains(&f.to_lowercase()) {
                continue;
            }
        }
        if props.api_version < vk::API_VERSION_1_3 {
            continue;
        }
        if !has_required_features(instance, pd) {
            continue;
        }
        // SAFETY: as above.
        let families = unsafe { instance.get_physical_device_queue_family_properties(pd) };
        let Some(family) = families.iter().position(|q| {
            q.queue_flags
                .contains(vk::QueueFlags::GRAPHICS | vk::QueueFlags::COMPUTE)
                && q.timestamp_valid_bits > 0
        }) else {
            continue;
        };
        let rank = match props.device_type {
            vk::PhysicalDeviceType::DISCRETE_GPU => 0,
            vk::PhysicalDeviceType::INTEGRATED_GPU => 1,
            vk::PhysicalDeviceType::VIRTUAL_GPU => 2,
            vk::PhysicalDeviceType::CPU => 3,
            _ => 4,
        };
        candidates.push((rank, pd, family as u32));
    }
    candidates.sort_by_key(|c| c.0);
    match candidates.first() {
        Some(&(_, pd, family)) => Ok((pd, family)),
        None => match filter {
            Some(f) => Err(anyhow!(
                "no Vulkan 1.3 device matches '{f}' (devices: {})",
                names.join(", ")
            )),
            None => Err(anyhow!(
                "no Vulkan 1.3 device with a graphics queue, timestamps, dynamic rendering, synchronization2, maintenance4 and host query reset (devices: {}): install the Debian package mesa-vulkan-drivers",
                names.join(", ")
            )),
        },
    }
}

/// vkCreateInstance's failure in words. The loader answers a driver manifest (ICD JSON) it
/// cannot parse with VK_ERROR_OUT_OF_HOST_MEMORY, which would read as a memory problem.
fn instance_error(e: vk::Result) -> anyhow::Error {
    let icd = ["VK_DRIVER_FILES", "VK_ICD_FILENAMES"]
        .iter()
        .find_map(|v| std::env::var(v).ok().map(|f| format!(" ({v}={f})")))
        .unwrap_or_default();
    match e {
        vk::Result::ERROR_OUT_OF_HOST_MEMORY | vk::Result::ERROR_INITIALIZATION_FAILED => anyhow!(
            "the Vulkan driver failed to load{icd}: its manifest (ICD JSON) or library is broken ({e})"
        ),
        vk::Result::ERROR_INCOMPATIBLE_DRIVER => anyhow!(
            "no Vulkan driver could be loaded{icd}: is a Vulkan 1.3 driver installed? Debian: mesa-vulkan-drivers ({e})"
        ),
        e => anyhow!(
            "creating the Vulkan instance{icd} (is a Vulkan 1.3 driver installed? Debian: mesa-vulkan-drivers): {e}"
        ),
    }
}
