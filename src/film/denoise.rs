//! Denoising with Intel Open Image Denoise (OIDN), loaded at run time.
//!
//! There is no link-time dependency: the binary builds and runs where OIDN is absent, and uses
//! the library Blender ships (official builds and the `bpy` wheel carry
//! `libOpenImageDenoise.so.2` / `OpenImageDenoise.dll` / `libOpenImageDenoise.2.dylib`) or the
//! system's. Both API generations are accepted: OIDN 2 (`oidnSetFilterBool`, ...) and OIDN 1
//! (`oidnSetFilter1b`, ...).
//!
//! The filter is OIDN's `RT` (path-traced images) on HDR linear Rec.709 colour with the
//! albedo and normal guides. By default the guides are first denoised by OIDN themselves
//! ("prefiltering", the OIDN manual's recommendation for the highest quality when guides can be
//! noisy, as ours are under depth of field, stochastic transparency and rough interfaces), then
//! the colour is filtered with `cleanAux` set. Quality and prefiltering are Cycles' options
//! (`DenoiseQuality`, `DenoisePrefilter`), with Cycles' defaults for final renders.

use glam::Vec3;
use libloading::Library;
use std::ffi::{c_char, c_void, CStr, CString};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};

/// The library's file names, most specific first.
#[cfg(target_os = "windows")]
const LIBRARY_NAMES: &[&str] = &["OpenImageDenoise.dll"];
#[cfg(target_os = "macos")]
const LIBRARY_NAMES: &[&str] = &[
    "libOpenImageDenoise.2.dylib",
    "libOpenImageDenoise.dylib",
    "libOpenImageDenoise.1.dylib",
];
#[cfg(not(any(target_os = "windows", target_os = "macos")))]
const LIBRARY_NAMES: &[&str] = &[
    "libOpenImageDenoise.so.2",
    "libOpenImageDenoise.so",
    "libOpenImageDenoise.so.1",
];

/// Memory OIDN may use for one filter (MB): above it OIDN denoises in overlapping tiles, so a
/// 4K or 8K image fits any machine Blender runs on. 3000 is OIDN 2's own CPU default, which
/// Cycles runs with (measured at 1080p on 2 threads: Cycles 32 s; Prism at 2048 MB 45 s).
const MAX_MEMORY_MB: i32 = 3000;

// OIDN's C enums (oidn.h, identical in versions 1 and 2).
const OIDN_DEVICE_TYPE_CPU: i32 = 1;
const OIDN_FORMAT_FLOAT3: i32 = 3;
const OIDN_ERROR_NONE: i32 = 0;

type Handle = *mut c_void;
type NewDevice = unsafe extern "C" fn(i32) -> Handle;
type DeviceFn = unsafe extern "C" fn(Handle);
type SetInt = unsafe extern "C" fn(Handle, *const c_char, i32);
type GetInt = unsafe extern "C" fn(Handle, *const c_char) -> i32;
type SetBool = unsafe extern "C" fn(Handle, *const c_char, bool);
type GetError = unsafe extern "C" fn(Handle, *mut *const c_char) -> i32;
type NewFilter = unsafe extern "C" fn(Handle, *const c_char) -> Handle;
/// `bool (*OIDNProgressMonitorFunction)(void* userPtr, double n)`: returning false cancels.
type ProgressMonitor = unsafe extern "C" fn(*mut c_void, f64) -> bool;
type SetProgressMonitor = unsafe extern "C" fn(Handle, Option<ProgressMonitor>, *mut c_void);
type SetImage = unsafe extern "C" fn(
    Handle,
    *const c_char,
    *mut c_void,
    i32,
    usize,
    usize,
    usize,
    usize,
    usize,
);

/// The entry points Prism uses, resolved once.
struct Api {
    new_device: NewDevice,
    set_device_int: SetInt,
    get_device_int: GetInt,
    commit_device: DeviceFn,
    release_device: DeviceFn,
    get_device_error: GetError,
    new_filter: NewFilter,
    set_shared_image: SetImage,
    set_filter_bool: SetBool,
    set_filter_int: SetInt,
    commit_filter: DeviceFn,
    execute_filter: DeviceFn,
    release_filter: DeviceFn,
    /// Absent before OIDN 1.3: such a filter cannot be cancelled.
    set_progress_monitor: Option<SetProgressMonitor>,
}

/// OIDN's filter quality (its `quality` parameter), as Cycles' Denoise > Quality.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum DenoiseQuality {
    /// The best network (Cycles' default for final renders).
    #[default]
    High,
    /// About 2x faster, slightly softer (Cycles' default for the viewport).
    Balanced,
    /// The fastest (OIDN 2.2 and later).
    Fast,
}

impl DenoiseQuality {
    pub const NAMES: &'static [&'static str] = &["high", "balanced", "fast"];

    pub fn from_name(name: &str) -> Option<Self> {
        match name {
            "high" => Some(DenoiseQuality::High),
            "balanced" => Some(DenoiseQuality::Balanced),
            "fast" => Some(DenoiseQuality::Fast),
            _ => None,
        }
    }

    /// OIDN's `OIDNQuality` value (oidn.h).
    fn oidn_value(self) -> i32 {
        match self {
            DenoiseQuality::High => 6,
            DenoiseQuality::Balanced => 5,
            DenoiseQuality::Fast => 4,
        }
    }
}

/// How the guides are treated, as Cycles' Denoise > Prefilter.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum DenoisePrefilter {
    /// Denoise the albedo and normal first, then the colour with clean guides (Cycles'
    /// default: the best result when the guides are noisy, three filter runs).
    #[default]
    Accurate,
    /// Denoise the colour with the guides as they are, telling OIDN they may be noisy (one run).
    Fast,
    /// Use the guides as they are and tell OIDN they are clean (one run; for noise-free guides).
    None,
}

impl DenoisePrefilter {
    pub const NAMES: &'static [&'static str] = &["accurate", "fast", "none"];

    pub fn from_name(name: &str) -> Option<Self> {
        match name {
            "accurate" => Some(DenoisePrefilter::Accurate),
            "fast" => Some(DenoisePrefilter::Fast),
            "none" => Some(DenoisePrefilter::None),
            _ => None,
        }
    }
}

/// How to denoise.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct DenoiseOptions {
    pub quality: DenoiseQuality,
    pub prefilter: DenoisePrefilter,
    /// Worker threads; 0 = all cores.
    pub threads: usize,
}

/// OIDN's progress callback: keep going unless the flag (`user`, an `AtomicBool`) is set.
unsafe extern "C" fn keep_going(user: *mut c_void, _progress: f64) -> bool {
    // SAFETY: `user` is the `&AtomicBool` given to `run_filter`, alive while the filter runs.
    let cancel = unsafe { &*(user as *const AtomicBool) };
    !cancel.load(Ordering::Relaxed)
}

impl DenoiseOptions {
    /// The options for progressive previews: at most Balanced quality and Fast prefiltering
    /// (Cycles' viewport defaults), so previews keep coming.
    pub fn for_previews(self) -> Self {
        DenoiseOptions {
            quality: match self.quality {
                DenoiseQuality::High => DenoiseQuality::Balanced,
                q => q,
            },
            prefilter: match self.prefilter {
                DenoisePrefilter::Accurate => DenoisePrefilter::Fast,
                p => p,
            },
            threads: self.threads,
        }
    }
}

/// A loaded OIDN library.
pub struct Oidn {
    api: Api,
    /// Where it was loaded from (a path, or a name the system's loader resolved).
    pub source: String,
    // Keeps the code behind `api` mapped; dropped last.
    _library: Library,
}

/// Where to look for the library.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum OidnLocation {
    /// A file, or a folder holding the library (Blender's `lib` folder).
    Path(PathBuf),
    /// The system's dynamic loader (and the folder of the running executable first).
    System,
}

impl OidnLocation {
    /// The library files or names to try, in order.
    fn candidates(&self) -> Vec<PathBuf> {
        match self {
            OidnLocation::Path(p) if p.is_dir() => {
                LIBRARY_NAMES.iter().map(|n| p.join(n)).collect()
            }
            OidnLocation::Path(p) => vec![p.clone()],
            OidnLocation::System => {
                let beside_exe = std::env::current_exe()
                    .ok()
                    .and_then(|e| e.parent().map(Path::to_path_buf));
                let mut out: Vec<PathBuf> = beside_exe
                    .iter()
                    .flat_map(|d| LIBRARY_NAMES.iter().map(move |n| d.join(n)))
                    .filter(|p| p.is_file())
                    .collect();
                out.extend(LIBRARY_NAMES.iter().map(PathBuf::from));
                out
            }
        }
    }
}

impl Oidn {
    /// Loads OIDN from `location`. The error is the one-line reason (for a warning).
    pub fn load(location: &OidnLocation) -> Result<Oidn, String> {
        let mut reasons = Vec::new();
        for candidate in location.candidates() {
            // SAFETY: loading runs the library's initialisers; OIDN's only set up its own state.
            match unsafe { Library::new(&candidate) } {
                Ok(lib) => {
                    let source = candidate.display().to_string();
                    let api = resolve(&lib).map_err(|e| format!("{source}: {e}"))?;
                    return Ok(Oidn {
                        api,
                        source,
                        _library: lib,
                    });
                }
                Err(e) => reasons.push(first_line(&e.to_string())),
            }
        }
        Err(match location {
            OidnLocation::System => format!(
                "Open Image Denoise not found ({}); give its path with --oidn or PRISM_OIDN",
                LIBRARY_NAMES.join(", ")
            ),
            OidnLocation::Path(_) => format!(
                "cannot load Open Image Denoise: {}",
                reasons.last().cloned().unwrap_or_default()
            ),
        })
    }

    /// Denoises `color` (linear Rec.709, HDR, row 0 = top) with optional albedo (in [0, 1])
    /// and normal guides (unit or zero vectors). The result is finite and non-negative
    /// wherever the input is. Setting `cancel` stops OIDN within moments (an error).
    #[allow(clippy::too_many_arguments)]
    pub fn denoise(
        &self,
        width: usize,
        height: usize,
        color: &[Vec3],
        albedo: Option<&[Vec3]>,
        normal: Option<&[Vec3]>,
        options: &DenoiseOptions,
        cancel: &AtomicBool,
    ) -> Result<Vec<Vec3>, String> {
        let n = width * height;
        if color.len() != n || albedo.is_some_and(|a| a.len() != n) {
            return Err("image and guides differ in size".into());
        }
        if normal.is_some_and(|a| a.len() != n) || normal.is_some() && albedo.is_none() {
            // OIDN takes a normal guide only together with an albedo guide.
            return Err("a normal guide needs an albedo guide".into());
        }
        let device = Device::new(&self.api, options.threads)?;
        let quality = options.quality;
        let accurate = options.prefilter == DenoisePrefilter::Accurate;
        // Accurate: prefilter the guides (each denoised on its own), then use them as clean.
        let prefilter = |name: &str, guide: &[Vec3]| -> Result<Vec<Vec3>, String> {
            if accurate {
                device.run_filter(&[(name, guide)], (width, height), quality, &[], cancel)
            } else {
                Ok(guide.to_vec())
            }
        };
        let albedo = albedo.map(|a| prefilter("albedo", a)).transpose()?;
        let normal = normal.map(|a| prefilter("normal", a)).transpose()?;
        let mut inputs = vec![("color", color)];
        if let Some(a) = &albedo {
            inputs.push(("albedo", a));
        }
        if let Some(nm) = &normal {
            inputs.push(("normal", nm));
        }
        let clean = albedo.is_some() && options.prefilter != DenoisePrefilter::Fast;
        let mut out = device.run_filter(
            &inputs,
            (width, height),
            quality,
            &[("hdr", true), ("cleanAux", clean)],
            cancel,
        )?;
        // Never hand on a non-finite or negative pixel: keep the noisy value there.
        for (o, c) in out.iter_mut().zip(color) {
            if !o.is_finite() {
                *o = *c;
            }
            *o = o.max(Vec3::ZERO);
        }
        Ok(out)
    }

    /// OIDN's version as major * 10000 + minor * 100 + patch (0 if it does not say).
    pub fn version(&self) -> i32 {
        Device::new(&self.api, 1)
            .map(|d| unsafe { (self.api.get_device_int)(d.handle, c"version".as_ptr()) })
            .unwrap_or(0)
    }
}

/// One OIDN CPU device, released on drop.
struct Device<'a> {
    api: &'a Api,
    handle: Handle,
}

impl<'a> Device<'a> {
    fn new(api: &'a Api, threads: usize) -> Result<Self, String> {
        // SAFETY: plain C calls on a handle we own; OIDN checks its arguments and reports
        // problems through oidnGetDeviceError.
        let handle = unsafe { (api.new_device)(OIDN_DEVICE_TYPE_CPU) };
        if handle.is_null() {
            return Err("OIDN could not create a CPU device".into());
        }
        let device = Device { api, handle };
        unsafe {
            (api.set_device_int)(
                handle,
                c"numThreads".as_ptr(),
                threads.min(i32::MAX as usize) as i32,
            );
            (api.commit_device)(handle);
        }
        device.check("creating the device")?;
        Ok(device)
    }

    /// The device's pending error, if any.
    fn check(&self, what: &str) -> Result<(), String> {
        let mut message: *const c_char = std::ptr::null();
        // SAFETY: OIDN writes a pointer to a message it owns (valid until the next call).
        let code = unsafe { (self.api.get_device_error)(self.handle, &mut message) };
        if code == OIDN_ERROR_NONE {
            return Ok(());
        }
        let text = if message.is_null() {
            String::new()
        } else {
            unsafe { CStr::from_ptr(message) }
                .to_string_lossy()
                .into_owned()
        };
        Err(format!(
            "OIDN failed {what} (error {code}): {}",
            first_line(&text)
        ))
    }

    /// Runs one `RT` filter over float3 images `inputs` (name, pixels) and returns its output.
    fn run_filter(
        &self,
        inputs: &[(&str, &[Vec3])],
        (width, height): (usize, usize),
        quality: DenoiseQuality,
        flags: &[(&str, bool)],
        cancel: &AtomicBool,
    ) -> Result<Vec<Vec3>, String> {
        let n = width * height;
        let api = self.api;
        // SAFETY: the filter is released below; every image outlives its execution; the
        // images are tightly packed float3 rows (Vec3 is three f32 with no padding).
        let filter = unsafe { (api.new_filter)(self.handle, c"RT".as_ptr()) };
        self.check("creating the RT filter")?;
        if filter.is_null() {
            return Err("OIDN has no RT filter".into());
        }
        struct Filter<'f>(&'f Api, Handle);
        impl Drop for Filter<'_> {
            fn drop(&mut self) {
                unsafe { (self.0.release_filter)(self.1) }
            }
        }
        let filter = Filter(api, filter);
        let mut output = vec![Vec3::ZERO; n];
        let stride = std::mem::size_of::<Vec3>();
        let set_image = |name: &str, data: *mut c_void| {
            let name = CString::new(name).expect("static names have no NUL");
            unsafe {
                (api.set_shared_image)(
                    filter.1,
                    name.as_ptr(),
                    data,
                    OIDN_FORMAT_FLOAT3,
                    width,
                    height,
                    0,
                    stride,
                    stride * width,
                )
            }
        };
        for (name, data) in inputs {
            // OIDN only reads its input images.
            set_image(name, data.as_ptr() as *mut c_void);
        }
        set_image("output", output.as_mut_ptr() as *mut c_void);
        unsafe {
            for (name, value) in flags {
                let name = CString::new(*name).expect("static names have no NUL");
                (api.set_filter_bool)(filter.1, name.as_ptr(), *value);
            }
            (api.set_filter_int)(filter.1, c"maxMemoryMB".as_ptr(), MAX_MEMORY_MB);
            if let Some(set_monitor) = api.set_progress_monitor {
                set_monitor(
                    filter.1,
                    Some(keep_going),
                    cancel as *const AtomicBool as *mut c_void,
                );
            }
            if quality != DenoiseQuality::High {
                // High is OIDN's default, and the only quality OIDN 1 knows: left unset.
                (api.set_filter_int)(filter.1, c"quality".as_ptr(), quality.oidn_value());
            }
            (api.commit_filter)(filter.1);
        }
        self.check("setting up the filter")?;
        unsafe { (api.execute_filter)(filter.1) };
        if cancel.load(Ordering::Relaxed) {
            return Err("denoising cancelled".into());
        }
        self.check("denoising")?;
        Ok(output)
    }
}

impl Drop for Device<'_> {
    fn drop(&mut self) {
        unsafe { (self.api.release_device)(self.handle) }
    }
}

/// Resolves the entry points, preferring OIDN 2's names and falling back to OIDN 1's.
fn resolve(lib: &Library) -> Result<Api, String> {
    fn get<T: Copy>(lib: &Library, names: &[&str]) -> Result<T, String> {
        for name in names {
            // SAFETY: the type T matches the C prototype of that name in oidn.h (1.x and 2.x).
            if let Ok(sym) = unsafe { lib.get::<T>(name.as_bytes()) } {
                return Ok(*sym);
            }
        }
        Err(format!(
            "not an Open Image Denoise library (no {})",
            names[0]
        ))
    }
    Ok(Api {
        new_device: get(lib, &["oidnNewDevice"])?,
        set_device_int: get(lib, &["oidnSetDeviceInt", "oidnSetDevice1i"])?,
        get_device_int: get(lib, &["oidnGetDeviceInt", "oidnGetDevice1i"])?,
        commit_device: get(lib, &["oidnCommitDevice"])?,
        release_device: get(lib, &["oidnReleaseDevice"])?,
        get_device_error: get(lib, &["oidnGetDeviceError"])?,
        new_filter: get(lib, &["oidnNewFilter"])?,
        set_shared_image: get(lib, &["oidnSetSharedFilterImage"])?,
        set_filter_bool: get(lib, &["oidnSetFilterBool", "oidnSetFilter1b"])?,
        set_filter_int: get(lib, &["oidnSetFilterInt", "oidnSetFilter1i"])?,
        commit_filter: get(lib, &["oidnCommitFilter"])?,
        execute_filter: get(lib, &["oidnExecuteFilter"])?,
        release_filter: get(lib, &["oidnReleaseFilter"])?,
        set_progress_monitor: get(lib, &["oidnSetFilterProgressMonitorFunction"]).ok(),
    })
}

fn first_line(s: &str) -> String {
    s.lines().next().unwrap_or("").trim().to_string()
}
