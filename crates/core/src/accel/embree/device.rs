//! The thin layer over `embree4-sys`: an owned Embree device whose errors
//! are collected as text (so building a scene can return them), the
//! ray/hit record laid out for the Embree library we actually link, and the
//! library's version.
//!
//! Why a padded ray/hit record: `embree4-sys` 0.0.10 generates its bindings
//! from the Embree 4.2.0 headers it bundles, where `RTCRayHit` is 80 bytes.
//! The Embree we link (4.4.0 from the `embreex` wheel) is built with
//! instance arrays (`RTC_GEOMETRY_INSTANCE_ARRAY`), which append
//! `instPrimID[1]` to `RTCHit`: `rtcIntersect1` writes 4 bytes at offset 80
//! on every hit (observed: it stores `RTC_INVALID_GEOMETRY_ID` there for a
//! plain hit, 0 for an instance hit). Every field before it is laid out as
//! in 4.2. [`RayHit`] is the 4.2 record followed by 16 spare bytes, so the
//! library's writes land in memory we own whichever way it was configured.

use embree4_sys as sys;
use std::ffi::{c_char, c_void, CStr};
use std::sync::Mutex;

use super::EmbreeError;

/// Embree's "no geometry" id (`RTC_INVALID_GEOMETRY_ID`).
pub(crate) const INVALID_ID: u32 = u32::MAX;

/// `RTCRayHit` plus room for the fields newer Embree builds append to
/// `RTCHit` (see the module docs). Pass a pointer to the whole record.
#[repr(C, align(16))]
#[derive(Clone, Copy)]
pub(crate) struct RayHit {
    pub rayhit: sys::RTCRayHit,
    /// Receives `instPrimID` (Embree ≥ 4.3 with instance arrays); unread.
    _tail: [u32; 4],
}

// The layout the padding argument rests on: if embree4-sys ever changes its
// record, this stops compiling instead of silently corrupting memory.
const _: () = assert!(std::mem::size_of::<sys::RTCRay>() == 48);
const _: () = assert!(std::mem::size_of::<sys::RTCHit>() == 32);
const _: () = assert!(std::mem::size_of::<sys::RTCRayHit>() == 80);
const _: () = assert!(std::mem::size_of::<RayHit>() == 96);

impl RayHit {
    /// A ray from `org` along `dir` over [tnear, tfar], with no hit yet.
    #[inline(always)]
    pub(crate) fn new(org: [f32; 3], dir: [f32; 3], tnear: f32, tfar: f32) -> Self {
        Self {
            rayhit: sys::RTCRayHit {
                ray: ray(org, dir, tnear, tfar),
                hit: sys::RTCHit {
                    Ng_x: 0.0,
                    Ng_y: 0.0,
                    Ng_z: 0.0,
                    u: 0.0,
                    v: 0.0,
                    primID: INVALID_ID,
                    geomID: INVALID_ID,
                    instID: [INVALID_ID],
                },
            },
            _tail: [INVALID_ID; 4],
        }
    }
}

#[cfg(test)]
impl RayHit {
    /// The spare bytes after the 4.2 record, as u32s.
    pub(crate) fn tail(&self) -> [u32; 4] {
        self._tail
    }

    /// Fill the spare bytes with a recognisable value.
    pub(crate) fn set_tail(&mut self, value: u32) {
        self._tail = [value; 4];
    }
}

/// An `RTCRay` for `rtcOccluded1` (whose record has not grown).
#[inline(always)]
pub(crate) fn ray(org: [f32; 3], dir: [f32; 3], tnear: f32, tfar: f32) -> sys::RTCRay {
    sys::RTCRay {
        org_x: org[0],
        org_y: org[1],
        org_z: org[2],
        tnear,
        dir_x: dir[0],
        dir_y: dir[1],
        dir_z: dir[2],
        time: 0.0,
        tfar,
        mask: u32::MAX,
        id: 0,
        flags: 0,
    }
}

/// Error messages reported by Embree's error callback, oldest first.
type ErrorLog = Mutex<Vec<String>>;

/// An Embree device. Errors Embree reports through its callback are kept
/// until [`Device::check`] turns them into an [`EmbreeError`].
pub(crate) struct Device {
    pub(crate) handle: sys::RTCDevice,
    /// Boxed so its address, given to Embree as the callback's user
    /// pointer, stays put when the `Device` moves.
    errors: Box<ErrorLog>,
}

// SAFETY: a `Device` owns its handle and its boxed log outright, and an
// Embree device is not tied to the thread that made it (Embree's API keeps
// an error flag per device *and user thread*: devices are used from many
// threads by design), so it may be used and released on another thread.
unsafe impl Send for Device {}
// SAFETY: through a `&Device` the only calls are `rtcGetDeviceProperty` on
// version properties (reads of constants), the error log's (a `Mutex`), and,
// in `scene.rs`, the creation of scenes and geometries, which happens only in
// `EmbreeAccel::build`, on one thread, before the device is shared. Embree
// may call `record_error` from any thread: it only locks the mutex.
unsafe impl Sync for Device {}

/// The callback Embree calls on every error. Declared with a plain `u32`
/// for the code rather than the generated `RTCError` enum, so a code newer
/// than the bundled headers know can never be an invalid enum value.
///
/// # Safety
/// `user` must point to a live [`ErrorLog`], and `message` be null or a
/// NUL-terminated string: what Embree passes once [`Device::new`] has
/// registered it (with the device's boxed log, which outlives the
/// registration).
unsafe extern "C" fn record_error(user: *mut c_void, code: u32, message: *const c_char) {
    // SAFETY: `user` is the `ErrorLog` registered in `Device::new`, alive
    // until the callback is unregistered in `Drop`.
    let log = unsafe { &*(user as *const ErrorLog) };
    let text = if message.is_null() {
        String::new()
    } else {
        // SAFETY: Embree passes a NUL-terminated string.
        unsafe { CStr::from_ptr(message) }
            .to_string_lossy()
            .into_owned()
    };
    let name = match code {
        1 => "unknown error",
        2 => "invalid argument",
        3 => "invalid operation",
        4 => "out of memory",
        5 => "unsupported CPU",
        6 => "cancelled",
        _ => "error",
    };
    if let Ok(mut log) = log.lock() {
        log.push(format!("{name} (code {code}): {text}"));
    }
}

type RawErrorCallback = unsafe extern "C" fn(*mut c_void, u32, *const c_char);
type BoundErrorCallback = unsafe extern "C" fn(*mut c_void, sys::RTCError, *const c_char);

impl Device {
    /// A CPU device with Embree's default configuration.
    pub(crate) fn new() -> Result<Self, EmbreeError> {
        // SAFETY: a null configuration string means "defaults".
        let handle = unsafe { sys::rtcNewDevice(std::ptr::null()) };
        if handle.is_null() {
            return Err(EmbreeError::new(
                "rtcNewDevice failed: Embree cannot run on this machine (no supported CPU?)",
            ));
        }
        let device = Self {
            handle,
            errors: Box::new(Mutex::new(Vec::new())),
        };
        // SAFETY: the two function types differ only in the second
        // parameter, u32 vs a `#[repr(u32)]` enum: the same ABI.
        let callback =
            unsafe { std::mem::transmute::<RawErrorCallback, BoundErrorCallback>(record_error) };
        let user = &*device.errors as *const ErrorLog as *mut c_void;
        // SAFETY: valid device; the log outlives the registration (Drop
        // unregisters before freeing it).
        unsafe { sys::rtcSetDeviceErrorFunction(handle, Some(callback), user) };
        let major = device.property(sys::RTCDeviceProperty::VERSION_MAJOR);
        if major != 4 {
            return Err(EmbreeError::new(format!(
                "the linked Embree library is version {}, not 4",
                device.version()
            )));
        }
        Ok(device)
    }

    fn property(&self, p: sys::RTCDeviceProperty) -> isize {
        // SAFETY: `handle` is a live device (non-null, released only in
        // `Drop`); version properties are always readable.
        unsafe { sys::rtcGetDeviceProperty(self.handle, p) }
    }

    /// The library's version, e.g. "4.4.0".
    pub(crate) fn version(&self) -> String {
        format!(
            "{}.{}.{}",
            self.property(sys::RTCDeviceProperty::VERSION_MAJOR),
            self.property(sys::RTCDeviceProperty::VERSION_MINOR),
            self.property(sys::RTCDeviceProperty::VERSION_PATCH)
        )
    }

    /// `Err` with every message Embree reported since the last check, if
    /// any, prefixed with what we were doing.
    pub(crate) fn check(&self, doing: &str) -> Result<(), EmbreeError> {
        let messages = match self.errors.lock() {
            Ok(mut log) => std::mem::take(&mut *log),
            Err(_) => vec!["error log poisoned".to_string()],
        };
        if messages.is_empty() {
            Ok(())
        } else {
            Err(EmbreeError::new(format!(
                "{doing}: {}",
                messages.join("; ")
            )))
        }
    }
}

impl Drop for Device {
    fn drop(&mut self) {
        // SAFETY: `handle` is a live device: this is its owner's release
        // point. Unregister first: scenes may keep the device alive past
        // this point, and the log the callback writes is freed with `self`.
        unsafe { sys::rtcSetDeviceErrorFunction(self.handle, None, std::ptr::null_mut()) };
        // SAFETY: the reference `rtcNewDevice` gave `new`, released once,
        // here; `handle` is not used again.
        unsafe { sys::rtcReleaseDevice(self.handle) };
    }
}
