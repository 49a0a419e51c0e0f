//! Everything specific to Embree 3 lives here: the hand-written `extern "C"`
//! declarations of the functions luz uses, the layouts of the structs it
//! exchanges with them (checked against `rtcore_*.h` by the tests at the
//! bottom), the constants, and the callback semantics (SOA ray packets,
//! `valid` masks, `tfar = -inf` for occlusion).
//!
//! On top of the raw layer sits a small RAII API ([`Device`], [`Scene`],
//! [`Geometry`], [`UserPrimitives`]) that speaks luz's own types. The backend
//! in `mod.rs` uses only that API, so an Embree 4 module (where
//! `rtcIntersect1` takes optional arguments instead of a context, the
//! callback argument structs change and the library is `embree4`) can sit
//! beside this one behind the same API.

#![allow(non_camel_case_types, non_snake_case, dead_code)]

use crate::math::{Aabb, Ray, Vec3};
use crate::scene::shape::PrimHit;
use std::ffi::{c_char, c_int, c_uint, c_void, CStr, CString};
use std::sync::Mutex;

mod config {
    include!(concat!(env!("OUT_DIR"), "/embree3_config.rs"));
}
const MAX_INST: usize = config::MAX_INSTANCE_LEVEL_COUNT;

// ---------------------------------------------------------------------------
// Raw layer: rtcore_common.h, rtcore_device.h, rtcore_buffer.h,
// rtcore_geometry.h, rtcore_scene.h, rtcore_ray.h of Embree 3.13.

#[repr(C)]
pub struct RTCDeviceTy {
    _opaque: [u8; 0],
}
#[repr(C)]
pub struct RTCSceneTy {
    _opaque: [u8; 0],
}
#[repr(C)]
pub struct RTCGeometryTy {
    _opaque: [u8; 0],
}
/// `struct RTCRayHitN` / `RTCRayN`: SOA packets, only reached through
/// pointers and the index arithmetic of `RTCRayN_*` / `RTCHitN_*`.
#[repr(C)]
pub struct RTCRayHitN {
    _opaque: [u8; 0],
}
#[repr(C)]
pub struct RTCRayN {
    _opaque: [u8; 0],
}

pub type RTCDevice = *mut RTCDeviceTy;
pub type RTCScene = *mut RTCSceneTy;
pub type RTCGeometry = *mut RTCGeometryTy;

// C enums are `int`-sized.
pub type RTCError = c_int;
pub type RTCDeviceProperty = c_int;
pub type RTCFormat = c_int;
pub type RTCBufferType = c_int;
pub type RTCGeometryType = c_int;
pub type RTCBuildQuality = c_int;
pub type RTCSceneFlags = c_int;
pub type RTCIntersectContextFlags = c_int;

pub const RTC_INVALID_GEOMETRY_ID: c_uint = c_uint::MAX;

pub const RTC_ERROR_NONE: RTCError = 0;
pub const RTC_ERROR_UNKNOWN: RTCError = 1;
pub const RTC_ERROR_INVALID_ARGUMENT: RTCError = 2;
pub const RTC_ERROR_INVALID_OPERATION: RTCError = 3;
pub const RTC_ERROR_OUT_OF_MEMORY: RTCError = 4;
pub const RTC_ERROR_UNSUPPORTED_CPU: RTCError = 5;
pub const RTC_ERROR_CANCELLED: RTCError = 6;

pub const RTC_DEVICE_PROPERTY_VERSION: RTCDeviceProperty = 0;
pub const RTC_DEVICE_PROPERTY_VERSION_MAJOR: RTCDeviceProperty = 1;
pub const RTC_DEVICE_PROPERTY_VERSION_MINOR: RTCDeviceProperty = 2;
pub const RTC_DEVICE_PROPERTY_VERSION_PATCH: RTCDeviceProperty = 3;

pub const RTC_FORMAT_UINT3: RTCFormat = 0x5003;
pub const RTC_FORMAT_FLOAT3: RTCFormat = 0x9003;

pub const RTC_BUFFER_TYPE_INDEX: RTCBufferType = 0;
pub const RTC_BUFFER_TYPE_VERTEX: RTCBufferType = 1;

pub const RTC_GEOMETRY_TYPE_TRIANGLE: RTCGeometryType = 0;
pub const RTC_GEOMETRY_TYPE_USER: RTCGeometryType = 120;

pub const RTC_BUILD_QUALITY_LOW: RTCBuildQuality = 0;
pub const RTC_BUILD_QUALITY_MEDIUM: RTCBuildQuality = 1;
pub const RTC_BUILD_QUALITY_HIGH: RTCBuildQuality = 2;

pub const RTC_SCENE_FLAG_NONE: RTCSceneFlags = 0;
pub const RTC_SCENE_FLAG_ROBUST: RTCSceneFlags = 1 << 2;

pub const RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT: RTCIntersectContextFlags = 0;

#[repr(C, align(16))]
#[derive(Clone, Copy, Debug, Default)]
pub struct RTCBounds {
    pub lower_x: f32,
    pub lower_y: f32,
    pub lower_z: f32,
    pub align0: f32,
    pub upper_x: f32,
    pub upper_y: f32,
    pub upper_z: f32,
    pub align1: f32,
}

#[repr(C)]
pub struct RTCFilterFunctionNArguments {
    pub valid: *mut c_int,
    pub geometryUserPtr: *mut c_void,
    pub context: *mut RTCIntersectContext,
    pub ray: *mut RTCRayN,
    pub hit: *mut c_void,
    pub N: c_uint,
}
pub type RTCFilterFunctionN =
    Option<unsafe extern "C" fn(args: *const RTCFilterFunctionNArguments)>;

#[repr(C)]
#[derive(Clone, Copy)]
pub struct RTCIntersectContext {
    pub flags: RTCIntersectContextFlags,
    pub filter: RTCFilterFunctionN,
    #[cfg(luz_embree_inst_stack)]
    pub instStackSize: c_uint,
    pub instID: [c_uint; MAX_INST],
    #[cfg(luz_embree_min_width)]
    pub minWidthDistanceFactor: f32,
}

impl RTCIntersectContext {
    /// `rtcInitIntersectContext`, inline in `rtcore_common.h`.
    pub fn new() -> Self {
        Self {
            flags: RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT,
            filter: None,
            #[cfg(luz_embree_inst_stack)]
            instStackSize: 0,
            instID: [RTC_INVALID_GEOMETRY_ID; MAX_INST],
            #[cfg(luz_embree_min_width)]
            minWidthDistanceFactor: 0.0,
        }
    }
}

impl Default for RTCIntersectContext {
    fn default() -> Self {
        Self::new()
    }
}

#[repr(C, align(16))]
#[derive(Clone, Copy, Debug, Default)]
pub struct RTCRay {
    pub org_x: f32,
    pub org_y: f32,
    pub org_z: f32,
    pub tnear: f32,
    pub dir_x: f32,
    pub dir_y: f32,
    pub dir_z: f32,
    pub time: f32,
    pub tfar: f32,
    pub mask: c_uint,
    pub id: c_uint,
    pub flags: c_uint,
}

#[repr(C, align(16))]
#[derive(Clone, Copy, Debug)]
pub struct RTCHit {
    pub Ng_x: f32,
    pub Ng_y: f32,
    pub Ng_z: f32,
    pub u: f32,
    pub v: f32,
    pub primID: c_uint,
    pub geomID: c_uint,
    pub instID: [c_uint; MAX_INST],
}

#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct RTCRayHit {
    pub ray: RTCRay,
    pub hit: RTCHit,
}

#[repr(C)]
pub struct RTCBoundsFunctionArguments {
    pub geometryUserPtr: *mut c_void,
    pub primID: c_uint,
    pub timeStep: c_uint,
    pub bounds_o: *mut RTCBounds,
}
pub type RTCBoundsFunction = Option<unsafe extern "C" fn(args: *const RTCBoundsFunctionArguments)>;

#[repr(C)]
pub struct RTCIntersectFunctionNArguments {
    pub valid: *mut c_int,
    pub geometryUserPtr: *mut c_void,
    pub primID: c_uint,
    pub context: *mut RTCIntersectContext,
    pub rayhit: *mut RTCRayHitN,
    pub N: c_uint,
    pub geomID: c_uint,
}
pub type RTCIntersectFunctionN =
    Option<unsafe extern "C" fn(args: *const RTCIntersectFunctionNArguments)>;

#[repr(C)]
pub struct RTCOccludedFunctionNArguments {
    pub valid: *mut c_int,
    pub geometryUserPtr: *mut c_void,
    pub primID: c_uint,
    pub context: *mut RTCIntersectContext,
    pub ray: *mut RTCRayN,
    pub N: c_uint,
    pub geomID: c_uint,
}
pub type RTCOccludedFunctionN =
    Option<unsafe extern "C" fn(args: *const RTCOccludedFunctionNArguments)>;

pub type RTCErrorFunction =
    Option<unsafe extern "C" fn(user_ptr: *mut c_void, code: RTCError, message: *const c_char)>;

// Linked by build.rs (`cargo:rustc-link-lib=embree3`).
extern "C" {
    pub fn rtcNewDevice(config: *const c_char) -> RTCDevice;
    pub fn rtcRetainDevice(device: RTCDevice);
    pub fn rtcReleaseDevice(device: RTCDevice);
    pub fn rtcGetDeviceProperty(device: RTCDevice, prop: RTCDeviceProperty) -> isize;
    pub fn rtcGetDeviceError(device: RTCDevice) -> RTCError;
    pub fn rtcSetDeviceErrorFunction(
        device: RTCDevice,
        error: RTCErrorFunction,
        user_ptr: *mut c_void,
    );

    pub fn rtcNewScene(device: RTCDevice) -> RTCScene;
    pub fn rtcReleaseScene(scene: RTCScene);
    pub fn rtcSetSceneBuildQuality(scene: RTCScene, quality: RTCBuildQuality);
    pub fn rtcSetSceneFlags(scene: RTCScene, flags: RTCSceneFlags);
    pub fn rtcAttachGeometryByID(scene: RTCScene, geometry: RTCGeometry, geom_id: c_uint);
    pub fn rtcCommitScene(scene: RTCScene);
    pub fn rtcIntersect1(
        scene: RTCScene,
        context: *mut RTCIntersectContext,
        rayhit: *mut RTCRayHit,
    );
    pub fn rtcOccluded1(scene: RTCScene, context: *mut RTCIntersectContext, ray: *mut RTCRay);

    pub fn rtcNewGeometry(device: RTCDevice, kind: RTCGeometryType) -> RTCGeometry;
    pub fn rtcReleaseGeometry(geometry: RTCGeometry);
    pub fn rtcCommitGeometry(geometry: RTCGeometry);
    pub fn rtcSetGeometryBuildQuality(geometry: RTCGeometry, quality: RTCBuildQuality);
    pub fn rtcSetNewGeometryBuffer(
        geometry: RTCGeometry,
        kind: RTCBufferType,
        slot: c_uint,
        format: RTCFormat,
        byte_stride: usize,
        item_count: usize,
    ) -> *mut c_void;
    pub fn rtcSetGeometryUserData(geometry: RTCGeometry, ptr: *mut c_void);
    pub fn rtcSetGeometryUserPrimitiveCount(geometry: RTCGeometry, count: c_uint);
    pub fn rtcSetGeometryBoundsFunction(
        geometry: RTCGeometry,
        bounds: RTCBoundsFunction,
        user_ptr: *mut c_void,
    );
    pub fn rtcSetGeometryIntersectFunction(geometry: RTCGeometry, intersect: RTCIntersectFunctionN);
    pub fn rtcSetGeometryOccludedFunction(geometry: RTCGeometry, occluded: RTCOccludedFunctionN);
}

fn error_name(code: RTCError) -> &'static str {
    match code {
        RTC_ERROR_NONE => "no error",
        RTC_ERROR_INVALID_ARGUMENT => "invalid argument",
        RTC_ERROR_INVALID_OPERATION => "invalid operation",
        RTC_ERROR_OUT_OF_MEMORY => "out of memory",
        RTC_ERROR_UNSUPPORTED_CPU => "unsupported CPU",
        RTC_ERROR_CANCELLED => "cancelled",
        _ => "unknown error",
    }
}

// ---------------------------------------------------------------------------
// Safe layer.

/// BVH build quality, as Embree names it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Quality {
    Low,
    Medium,
    High,
}

impl Quality {
    fn raw(self) -> RTCBuildQuality {
        match self {
            Quality::Low => RTC_BUILD_QUALITY_LOW,
            Quality::Medium => RTC_BUILD_QUALITY_MEDIUM,
            Quality::High => RTC_BUILD_QUALITY_HIGH,
        }
    }
}

/// What Embree's error callback reported since the last check.
#[derive(Default)]
struct ErrorSink {
    messages: Mutex<Vec<String>>,
}

unsafe extern "C" fn record_error(user_ptr: *mut c_void, code: RTCError, message: *const c_char) {
    // SAFETY: `user_ptr` is the `ErrorSink` boxed inside the `Device`, which
    // outlives every call Embree makes on it; `message` is a C string or null.
    let sink = unsafe { &*(user_ptr as *const ErrorSink) };
    let text = if message.is_null() {
        String::new()
    } else {
        unsafe { CStr::from_ptr(message) }
            .to_string_lossy()
            .into_owned()
    };
    let line = if text.is_empty() {
        error_name(code).to_string()
    } else {
        format!("{} ({})", text, error_name(code))
    };
    if let Ok(mut m) = sink.messages.lock() {
        m.push(line);
    }
}

/// An Embree device with an error callback that records Embree's messages.
pub struct Device {
    raw: RTCDevice,
    // Boxed: Embree holds its address.
    sink: Box<ErrorSink>,
}

// SAFETY: Embree devices are thread-safe; the sink is behind a mutex.
unsafe impl Send for Device {}
unsafe impl Sync for Device {}

impl Device {
    /// `rtcNewDevice(config)`; `None` is Embree's default configuration.
    pub fn new(config: Option<&str>) -> Result<Self, String> {
        let config = config
            .map(CString::new)
            .transpose()
            .map_err(|_| "device configuration contains a NUL byte".to_string())?;
        let ptr = config.as_ref().map_or(std::ptr::null(), |c| c.as_ptr());
        // SAFETY: `ptr` is null or a valid C string for the call.
        let raw = unsafe { rtcNewDevice(ptr) };
        if raw.is_null() {
            // The error of a failed device creation is read with a null device.
            let code = unsafe { rtcGetDeviceError(std::ptr::null_mut()) };
            return Err(format!("rtcNewDevice failed: {}", error_name(code)));
        }
        let device = Self {
            raw,
            sink: Box::default(),
        };
        // SAFETY: the sink lives as long as the device (both owned here).
        unsafe {
            rtcSetDeviceErrorFunction(
                raw,
                Some(record_error),
                &*device.sink as *const ErrorSink as *mut c_void,
            )
        };
        Ok(device)
    }

    /// The library's version, "3.13.5".
    pub fn version(&self) -> String {
        let p = |prop| unsafe { rtcGetDeviceProperty(self.raw, prop) };
        format!(
            "{}.{}.{}",
            p(RTC_DEVICE_PROPERTY_VERSION_MAJOR),
            p(RTC_DEVICE_PROPERTY_VERSION_MINOR),
            p(RTC_DEVICE_PROPERTY_VERSION_PATCH)
        )
    }

    /// Any error Embree reported since the last check, with `what` (the call
    /// that was made) and Embree's own message.
    pub fn check(&self, what: &str) -> Result<(), String> {
        // SAFETY: valid device. Reading also clears this thread's error code.
        let code = unsafe { rtcGetDeviceError(self.raw) };
        let messages = std::mem::take(&mut *self.sink.messages.lock().expect("sink lock"));
        if code == RTC_ERROR_NONE && messages.is_empty() {
            return Ok(());
        }
        let detail = if messages.is_empty() {
            error_name(code).to_string()
        } else {
            messages.join("; ")
        };
        Err(format!("{what}: {detail}"))
    }

    pub fn new_scene(&self, quality: Quality, robust: bool) -> Result<Scene, String> {
        // SAFETY: valid device; a null scene is checked below.
        let raw = unsafe { rtcNewScene(self.raw) };
        self.check("rtcNewScene")?;
        if raw.is_null() {
            return Err("rtcNewScene returned null".into());
        }
        let scene = Scene { raw };
        unsafe {
            rtcSetSceneBuildQuality(raw, quality.raw());
            rtcSetSceneFlags(
                raw,
                if robust {
                    RTC_SCENE_FLAG_ROBUST
                } else {
                    RTC_SCENE_FLAG_NONE
                },
            );
        }
        self.check("rtcSetSceneFlags")?;
        Ok(scene)
    }

    fn new_geometry(&self, kind: RTCGeometryType) -> Result<Geometry, String> {
        // SAFETY: valid device.
        let raw = unsafe { rtcNewGeometry(self.raw, kind) };
        self.check("rtcNewGeometry")?;
        if raw.is_null() {
            return Err("rtcNewGeometry returned null".into());
        }
        Ok(Geometry { raw })
    }

    /// A committed triangle mesh. Embree copies the data into buffers it
    /// allocates (with the padding its SSE loads need). Every index must be
    /// below `positions.len()`: Embree does not check.
    pub fn new_triangles(
        &self,
        positions: &[Vec3],
        indices: &[[u32; 3]],
        quality: Quality,
    ) -> Result<Geometry, String> {
        assert!(indices
            .iter()
            .all(|t| t.iter().all(|&i| (i as usize) < positions.len())));
        let geom = self.new_geometry(RTC_GEOMETRY_TYPE_TRIANGLE)?;
        unsafe {
            rtcSetGeometryBuildQuality(geom.raw, quality.raw());
            let v = rtcSetNewGeometryBuffer(
                geom.raw,
                RTC_BUFFER_TYPE_VERTEX,
                0,
                RTC_FORMAT_FLOAT3,
                12,
                positions.len(),
            ) as *mut [f32; 3];
            self.check("rtcSetNewGeometryBuffer(vertex)")?;
            if v.is_null() {
                return Err("rtcSetNewGeometryBuffer(vertex) returned null".into());
            }
            // SAFETY: Embree allocated `positions.len()` float3 items.
            let v = std::slice::from_raw_parts_mut(v, positions.len());
            for (dst, p) in v.iter_mut().zip(positions) {
                *dst = p.to_array();
            }
            let ix = rtcSetNewGeometryBuffer(
                geom.raw,
                RTC_BUFFER_TYPE_INDEX,
                0,
                RTC_FORMAT_UINT3,
                12,
                indices.len(),
            ) as *mut [u32; 3];
            self.check("rtcSetNewGeometryBuffer(index)")?;
            if ix.is_null() {
                return Err("rtcSetNewGeometryBuffer(index) returned null".into());
            }
            std::slice::from_raw_parts_mut(ix, indices.len()).copy_from_slice(indices);
            rtcCommitGeometry(geom.raw);
        }
        self.check("rtcCommitGeometry(triangles)")?;
        Ok(geom)
    }

    /// A committed user geometry of `count` primitives whose callbacks call
    /// `prims`.
    ///
    /// # Safety
    /// `prims` must stay valid, and not move, for as long as any scene the
    /// geometry is attached to is used.
    pub unsafe fn new_user<T: UserPrimitives>(
        &self,
        prims: *const T,
        count: u32,
    ) -> Result<Geometry, String> {
        let geom = self.new_geometry(RTC_GEOMETRY_TYPE_USER)?;
        let user = prims as *mut c_void;
        unsafe {
            rtcSetGeometryUserPrimitiveCount(geom.raw, count);
            rtcSetGeometryUserData(geom.raw, user);
            rtcSetGeometryBoundsFunction(geom.raw, Some(bounds_fn::<T>), user);
            rtcSetGeometryIntersectFunction(geom.raw, Some(intersect_fn::<T>));
            rtcSetGeometryOccludedFunction(geom.raw, Some(occluded_fn::<T>));
            rtcCommitGeometry(geom.raw);
        }
        self.check("rtcCommitGeometry(user)")?;
        Ok(geom)
    }

    /// Attaches `geom` to `scene` under the id `geom_id` (the scene keeps its
    /// own reference; `geom` may be dropped afterwards).
    pub fn attach(&self, scene: &Scene, geom: &Geometry, geom_id: u32) -> Result<(), String> {
        unsafe { rtcAttachGeometryByID(scene.raw, geom.raw, geom_id) };
        self.check("rtcAttachGeometryByID")
    }

    /// Builds the BVH; afterwards the scene is read-only and thread-safe.
    pub fn commit(&self, scene: &Scene) -> Result<(), String> {
        unsafe { rtcCommitScene(scene.raw) };
        self.check("rtcCommitScene")
    }
}

impl Drop for Device {
    fn drop(&mut self) {
        // SAFETY: we own one reference; scenes keep their own.
        unsafe {
            rtcSetDeviceErrorFunction(self.raw, None, std::ptr::null_mut());
            rtcReleaseDevice(self.raw);
        }
    }
}

/// A geometry handle (one reference).
pub struct Geometry {
    raw: RTCGeometry,
}

impl Drop for Geometry {
    fn drop(&mut self) {
        unsafe { rtcReleaseGeometry(self.raw) };
    }
}

/// A scene handle (one reference). Committed scenes are traversed from many
/// threads at once, which Embree allows.
pub struct Scene {
    raw: RTCScene,
}

// SAFETY: a committed Embree scene is immutable and thread-safe for
// rtcIntersect1/rtcOccluded1; luz never modifies it after the commit.
unsafe impl Send for Scene {}
unsafe impl Sync for Scene {}

impl Drop for Scene {
    fn drop(&mut self) {
        unsafe { rtcReleaseScene(self.raw) };
    }
}

/// A closest hit as Embree reports it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RawHit {
    pub t: f32,
    pub geom: u32,
    pub prim: u32,
    pub u: f32,
    pub v: f32,
}

fn to_rtc_ray(ray: &Ray) -> RTCRay {
    RTCRay {
        org_x: ray.origin.x,
        org_y: ray.origin.y,
        org_z: ray.origin.z,
        tnear: ray.t_min,
        dir_x: ray.dir.x,
        dir_y: ray.dir.y,
        dir_z: ray.dir.z,
        time: 0.0,
        tfar: ray.t_max,
        mask: u32::MAX,
        id: 0,
        flags: 0,
    }
}

impl Scene {
    /// Closest hit in the ray's interval (Embree's: `tnear < t <= tfar` for
    /// its triangles; user primitives use luz's open interval).
    #[inline]
    pub fn intersect(&self, ray: &Ray) -> Option<RawHit> {
        let mut rh = RTCRayHit {
            ray: to_rtc_ray(ray),
            hit: RTCHit {
                Ng_x: 0.0,
                Ng_y: 0.0,
                Ng_z: 0.0,
                u: 0.0,
                v: 0.0,
                primID: RTC_INVALID_GEOMETRY_ID,
                geomID: RTC_INVALID_GEOMETRY_ID,
                instID: [RTC_INVALID_GEOMETRY_ID; MAX_INST],
            },
        };
        let mut ctx = RTCIntersectContext::new();
        // SAFETY: committed scene; both structs live across the call.
        unsafe { rtcIntersect1(self.raw, &mut ctx, &mut rh) };
        (rh.hit.geomID != RTC_INVALID_GEOMETRY_ID).then_some(RawHit {
            t: rh.ray.tfar,
            geom: rh.hit.geomID,
            prim: rh.hit.primID,
            u: rh.hit.u,
            v: rh.hit.v,
        })
    }

    /// Whether anything is hit in the ray's interval.
    #[inline]
    pub fn occluded(&self, ray: &Ray) -> bool {
        let mut r = to_rtc_ray(ray);
        let mut ctx = RTCIntersectContext::new();
        // SAFETY: committed scene; both structs live across the call.
        unsafe { rtcOccluded1(self.raw, &mut ctx, &mut r) };
        r.tfar == f32::NEG_INFINITY
    }
}

/// Primitives Embree does not know, intersected by luz's own routines.
pub trait UserPrimitives: Sync {
    /// Finite bounds of primitive `prim`.
    fn bounds(&self, prim: u32) -> Aabb;
    /// Closest hit in `(ray.t_min, ray.t_max)`.
    fn intersect(&self, prim: u32, ray: &Ray) -> Option<PrimHit>;
    /// Whether `prim` is hit in `(ray.t_min, ray.t_max)`.
    fn occluded(&self, prim: u32, ray: &Ray) -> bool;
}

unsafe extern "C" fn bounds_fn<T: UserPrimitives>(args: *const RTCBoundsFunctionArguments) {
    // SAFETY: Embree passes valid arguments; the user pointer is a `T`.
    let args = unsafe { &*args };
    let prims = unsafe { &*(args.geometryUserPtr as *const T) };
    let b = prims.bounds(args.primID);
    unsafe {
        *args.bounds_o = RTCBounds {
            lower_x: b.min.x,
            lower_y: b.min.y,
            lower_z: b.min.z,
            align0: 0.0,
            upper_x: b.max.x,
            upper_y: b.max.y,
            upper_z: b.max.z,
            align1: 0.0,
        };
    }
}

/// Ray `i` of an SOA packet of `n` (`RTCRayN_*` of `rtcore_ray.h`).
#[inline]
unsafe fn read_ray_n(ray: *const f32, n: usize, i: usize) -> Ray {
    let f = |k: usize| unsafe { *ray.add(k * n + i) };
    Ray {
        origin: Vec3::new(f(0), f(1), f(2)),
        t_min: f(3),
        dir: Vec3::new(f(4), f(5), f(6)),
        t_max: f(8),
    }
}

unsafe extern "C" fn intersect_fn<T: UserPrimitives>(args: *const RTCIntersectFunctionNArguments) {
    // SAFETY: Embree passes a valid packet of `N` rays, a `valid` mask of
    // `N` ints, and the user pointer given at creation (a `T`).
    let args = unsafe { &*args };
    let prims = unsafe { &*(args.geometryUserPtr as *const T) };
    let n = args.N as usize;
    let ray = args.rayhit as *mut f32;
    // RTCRayHitN_HitN: the hit follows the 12 ray fields.
    let hit = unsafe { ray.add(12 * n) };
    for i in 0..n {
        if unsafe { *args.valid.add(i) } == 0 {
            continue;
        }
        let r = unsafe { read_ray_n(ray, n, i) };
        if let Some(h) = prims.intersect(args.primID, &r) {
            unsafe {
                *ray.add(8 * n + i) = h.t;
                // Ng is left zero: nothing reads it (`Scene::intersect`
                // returns no normal; luz rebuilds the surface from the hit),
                // so computing one per candidate hit would be wasted work.
                *hit.add(i) = 0.0;
                *hit.add(n + i) = 0.0;
                *hit.add(2 * n + i) = 0.0;
                *hit.add(3 * n + i) = h.u;
                *hit.add(4 * n + i) = h.v;
                let ids = hit as *mut c_uint;
                *ids.add(5 * n + i) = args.primID;
                *ids.add(6 * n + i) = args.geomID;
                let ctx = &*args.context;
                for (l, &inst) in ctx.instID.iter().enumerate() {
                    *ids.add(7 * n + i + n * l) = inst;
                }
            }
        }
    }
}

unsafe extern "C" fn occluded_fn<T: UserPrimitives>(args: *const RTCOccludedFunctionNArguments) {
    // SAFETY: as in `intersect_fn`.
    let args = unsafe { &*args };
    let prims = unsafe { &*(args.geometryUserPtr as *const T) };
    let n = args.N as usize;
    let ray = args.ray as *mut f32;
    for i in 0..n {
        if unsafe { *args.valid.add(i) } == 0 {
            continue;
        }
        let r = unsafe { read_ray_n(ray, n, i) };
        if prims.occluded(args.primID, &r) {
            // Embree 3's convention for "occluded".
            unsafe { *ray.add(8 * n + i) = f32::NEG_INFINITY };
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::mem::{align_of, offset_of, size_of};

    #[test]
    fn ray_and_hit_layouts_match_rtcore_ray_h() {
        assert_eq!(size_of::<RTCRay>(), 48);
        assert_eq!(align_of::<RTCRay>(), 16);
        assert_eq!(offset_of!(RTCRay, org_x), 0);
        assert_eq!(offset_of!(RTCRay, tnear), 12);
        assert_eq!(offset_of!(RTCRay, dir_x), 16);
        assert_eq!(offset_of!(RTCRay, time), 28);
        assert_eq!(offset_of!(RTCRay, tfar), 32);
        assert_eq!(offset_of!(RTCRay, mask), 36);
        assert_eq!(offset_of!(RTCRay, id), 40);
        assert_eq!(offset_of!(RTCRay, flags), 44);

        let hit_unpadded = 28 + 4 * MAX_INST;
        assert_eq!(size_of::<RTCHit>(), hit_unpadded.div_ceil(16) * 16);
        assert_eq!(align_of::<RTCHit>(), 16);
        assert_eq!(offset_of!(RTCHit, Ng_x), 0);
        assert_eq!(offset_of!(RTCHit, u), 12);
        assert_eq!(offset_of!(RTCHit, v), 16);
        assert_eq!(offset_of!(RTCHit, primID), 20);
        assert_eq!(offset_of!(RTCHit, geomID), 24);
        assert_eq!(offset_of!(RTCHit, instID), 28);

        assert_eq!(offset_of!(RTCRayHit, ray), 0);
        assert_eq!(offset_of!(RTCRayHit, hit), 48);
        assert_eq!(align_of::<RTCRayHit>(), 16);
        if MAX_INST == 1 {
            assert_eq!(size_of::<RTCRayHit>(), 80);
        }
        // The SOA accessors read the hit after 12 ray fields.
        assert_eq!(size_of::<RTCRay>(), 12 * 4);
    }

    #[test]
    fn bounds_and_context_layouts_match_rtcore_common_h() {
        assert_eq!(size_of::<RTCBounds>(), 32);
        assert_eq!(align_of::<RTCBounds>(), 16);
        assert_eq!(offset_of!(RTCBounds, upper_x), 16);

        assert_eq!(offset_of!(RTCIntersectContext, flags), 0);
        assert_eq!(offset_of!(RTCIntersectContext, filter), 8);
        #[cfg(not(any(luz_embree_inst_stack, luz_embree_min_width)))]
        {
            assert_eq!(offset_of!(RTCIntersectContext, instID), 16);
            assert_eq!(
                size_of::<RTCIntersectContext>(),
                (16 + 4 * MAX_INST).div_ceil(8) * 8
            );
        }
        if cfg!(not(any(luz_embree_inst_stack, luz_embree_min_width))) && MAX_INST == 1 {
            assert_eq!(size_of::<RTCIntersectContext>(), 24);
        }
    }

    #[test]
    fn callback_argument_layouts_match_rtcore_geometry_h() {
        assert_eq!(offset_of!(RTCBoundsFunctionArguments, primID), 8);
        assert_eq!(offset_of!(RTCBoundsFunctionArguments, timeStep), 12);
        assert_eq!(offset_of!(RTCBoundsFunctionArguments, bounds_o), 16);
        assert_eq!(size_of::<RTCBoundsFunctionArguments>(), 24);

        assert_eq!(offset_of!(RTCIntersectFunctionNArguments, valid), 0);
        assert_eq!(
            offset_of!(RTCIntersectFunctionNArguments, geometryUserPtr),
            8
        );
        assert_eq!(offset_of!(RTCIntersectFunctionNArguments, primID), 16);
        assert_eq!(offset_of!(RTCIntersectFunctionNArguments, context), 24);
        assert_eq!(offset_of!(RTCIntersectFunctionNArguments, rayhit), 32);
        assert_eq!(offset_of!(RTCIntersectFunctionNArguments, N), 40);
        assert_eq!(offset_of!(RTCIntersectFunctionNArguments, geomID), 44);
        assert_eq!(size_of::<RTCIntersectFunctionNArguments>(), 48);

        assert_eq!(offset_of!(RTCOccludedFunctionNArguments, ray), 32);
        assert_eq!(offset_of!(RTCOccludedFunctionNArguments, N), 40);
        assert_eq!(offset_of!(RTCOccludedFunctionNArguments, geomID), 44);
        assert_eq!(size_of::<RTCOccludedFunctionNArguments>(), 48);

        assert_eq!(offset_of!(RTCFilterFunctionNArguments, N), 40);
    }

    #[test]
    fn library_version_matches_the_header() {
        let d = Device::new(None).unwrap();
        assert_eq!(d.version(), config::HEADER_VERSION);
        let v = unsafe { rtcGetDeviceProperty(d.raw, RTC_DEVICE_PROPERTY_VERSION) };
        assert_eq!(v / 10000, 3);
    }

    #[test]
    fn embree_errors_reach_the_caller_with_embrees_message() {
        let d = Device::new(None).unwrap();
        let s = d.new_scene(Quality::Medium, false).unwrap();
        let g = d.new_triangles(
            &[Vec3::ZERO, Vec3::X, Vec3::Y],
            &[[0, 1, 2]],
            Quality::Medium,
        );
        let g = g.unwrap();
        d.attach(&s, &g, 3).unwrap();
        // The same id twice is an invalid operation.
        let err = d.attach(&s, &g, 3).unwrap_err();
        // "rtcAttachGeometryByID: invalid geometry ID provided (invalid operation)"
        assert!(err.starts_with("rtcAttachGeometryByID: "), "{err}");
        assert!(err.contains("invalid"), "{err}");
        // Errors are consumed by the check that reports them.
        d.check("nothing").unwrap();
        // A configuration Embree cannot parse fails the device creation.
        let err = Device::new(Some("threads=abc")).err().unwrap();
        assert!(err.starts_with("rtcNewDevice failed"), "{err}");
    }
}
