//! Hand-written declarations for the part of the Embree 3 C API the peer uses, transcribed from
//! the headers of Debian's `libembree-dev` 3.13.5 (`/usr/include/embree3/rtcore_*.h`).
//!
//! The struct layouts depend on two build options of the library, `RTC_MAX_INSTANCE_LEVEL_COUNT`
//! (1 here: one `instID` per hit and no `instStackSize` in the context) and `RTC_MIN_WIDTH` (0:
//! no `minWidthDistanceFactor`); `build.rs` checks the installed `rtcore_config.h` for both. The
//! sizes, alignments and offsets asserted below were printed by a C program compiled against that
//! header (`sizeof`, `_Alignof`, `offsetof`).
//!
//! C enums are passed as `c_uint`/`c_int` constants: every enum here has non-negative values that
//! fit an `int`, and the C ABI on the supported targets passes such enums as a 32-bit integer.

use core::ffi::{c_char, c_int, c_uint, c_void};
use core::mem::{align_of, offset_of, size_of};

/// Opaque `struct RTCDeviceTy`.
#[repr(C)]
pub struct RTCDeviceTy {
    _private: [u8; 0],
}
/// Opaque `struct RTCSceneTy`.
#[repr(C)]
pub struct RTCSceneTy {
    _private: [u8; 0],
}
/// Opaque `struct RTCGeometryTy`.
#[repr(C)]
pub struct RTCGeometryTy {
    _private: [u8; 0],
}
pub type RTCDevice = *mut RTCDeviceTy;
pub type RTCScene = *mut RTCSceneTy;
pub type RTCGeometry = *mut RTCGeometryTy;

/// `RTC_INVALID_GEOMETRY_ID`: `geomID` of a miss, and the empty instance stack.
pub const RTC_INVALID_GEOMETRY_ID: c_uint = c_uint::MAX;
/// `RTC_MAX_INSTANCE_LEVEL_COUNT` of the library build (checked by `build.rs`).
pub const RTC_MAX_INSTANCE_LEVEL_COUNT: usize = 1;

// enum RTCError (rtcore_device.h)
pub type RTCError = c_uint;
pub const RTC_ERROR_NONE: RTCError = 0;

// enum RTCDeviceProperty (rtcore_device.h)
pub type RTCDeviceProperty = c_uint;
pub const RTC_DEVICE_PROPERTY_VERSION: RTCDeviceProperty = 0;
pub const RTC_DEVICE_PROPERTY_NATIVE_RAY8_SUPPORTED: RTCDeviceProperty = 33;
pub const RTC_DEVICE_PROPERTY_BACKFACE_CULLING_ENABLED: RTCDeviceProperty = 65;

// enum RTCGeometryType (rtcore_geometry.h)
pub type RTCGeometryType = c_uint;
pub const RTC_GEOMETRY_TYPE_TRIANGLE: RTCGeometryType = 0;

// enum RTCBufferType (rtcore_buffer.h)
pub type RTCBufferType = c_uint;
pub const RTC_BUFFER_TYPE_INDEX: RTCBufferType = 0;
pub const RTC_BUFFER_TYPE_VERTEX: RTCBufferType = 1;

// enum RTCFormat (rtcore_common.h): RTC_FORMAT_UINT = 0x5001, FLOAT = 0x9001, then 2, 3, 4 wide.
pub type RTCFormat = c_uint;
pub const RTC_FORMAT_UINT3: RTCFormat = 0x5003;
pub const RTC_FORMAT_FLOAT3: RTCFormat = 0x9003;

// enum RTCBuildQuality (rtcore_common.h)
pub type RTCBuildQuality = c_uint;
pub const RTC_BUILD_QUALITY_MEDIUM: RTCBuildQuality = 1;
pub const RTC_BUILD_QUALITY_HIGH: RTCBuildQuality = 2;

// enum RTCIntersectContextFlags (rtcore_common.h)
pub type RTCIntersectContextFlags = c_uint;
pub const RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT: RTCIntersectContextFlags = 0;
/// `RTC_INTERSECT_CONTEXT_FLAG_COHERENT`: the rays of a stream call are coherent (primary rays).
pub const RTC_INTERSECT_CONTEXT_FLAG_COHERENT: RTCIntersectContextFlags = 1;

/// `struct RTCRay` (rtcore_ray.h): one ray; `tfar` is overwritten with the hit distance.
#[repr(C, align(16))]
#[derive(Clone, Copy, Debug)]
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

/// `struct RTCHit` (rtcore_ray.h).
#[repr(C, align(16))]
#[derive(Clone, Copy, Debug)]
pub struct RTCHit {
    pub ng_x: f32,
    pub ng_y: f32,
    pub ng_z: f32,
    pub u: f32,
    pub v: f32,
    pub prim_id: c_uint,
    pub geom_id: c_uint,
    pub inst_id: [c_uint; RTC_MAX_INSTANCE_LEVEL_COUNT],
}

/// `struct RTCRayHit` (rtcore_ray.h).
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct RTCRayHit {
    pub ray: RTCRay,
    pub hit: RTCHit,
}

/// `struct RTCRay8` (rtcore_ray.h): 8 rays, structure of arrays, 32-byte aligned.
#[repr(C, align(32))]
#[derive(Clone, Copy, Debug)]
pub struct RTCRay8 {
    pub org_x: [f32; 8],
    pub org_y: [f32; 8],
    pub org_z: [f32; 8],
    pub tnear: [f32; 8],
    pub dir_x: [f32; 8],
    pub dir_y: [f32; 8],
    pub dir_z: [f32; 8],
    pub time: [f32; 8],
    pub tfar: [f32; 8],
    pub mask: [c_uint; 8],
    pub id: [c_uint; 8],
    pub flags: [c_uint; 8],
}

/// `struct RTCHit8` (rtcore_ray.h).
#[repr(C, align(32))]
#[derive(Clone, Copy, Debug)]
pub struct RTCHit8 {
    pub ng_x: [f32; 8],
    pub ng_y: [f32; 8],
    pub ng_z: [f32; 8],
    pub u: [f32; 8],
    pub v: [f32; 8],
    pub prim_id: [c_uint; 8],
    pub geom_id: [c_uint; 8],
    pub inst_id: [[c_uint; 8]; RTC_MAX_INSTANCE_LEVEL_COUNT],
}

/// `struct RTCRayHit8` (rtcore_ray.h).
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct RTCRayHit8 {
    pub ray: RTCRay8,
    pub hit: RTCHit8,
}

/// The `const int* valid` argument of `rtcIntersect8`: −1 for an active lane, 0 for an inactive
/// one. Embree requires it 32-byte aligned, like the packet.
#[repr(C, align(32))]
#[derive(Clone, Copy, Debug)]
pub struct Valid8(pub [c_int; 8]);

/// `RTCFilterFunctionN`; the peer never installs one, only the field's type matters.
pub type RTCFilterFunctionN = Option<unsafe extern "C" fn(args: *const c_void)>;

/// `struct RTCIntersectContext` (rtcore_common.h) for `RTC_MAX_INSTANCE_LEVEL_COUNT == 1`
/// (no `instStackSize`) and `RTC_MIN_WIDTH == 0` (no `minWidthDistanceFactor`).
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct RTCIntersectContext {
    pub flags: RTCIntersectContextFlags,
    pub filter: RTCFilterFunctionN,
    pub inst_id: [c_uint; RTC_MAX_INSTANCE_LEVEL_COUNT],
}

/// `rtcInitIntersectContext`, a `RTC_FORCEINLINE` function in rtcore_common.h and so not exported
/// by the library: incoherent rays, no filter, an empty instance stack.
pub fn rtc_init_intersect_context() -> RTCIntersectContext {
    RTCIntersectContext {
        flags: RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT,
        filter: None,
        inst_id: [RTC_INVALID_GEOMETRY_ID; RTC_MAX_INSTANCE_LEVEL_COUNT],
    }
}

// Layouts as printed by C against /usr/include/embree3 (x86_64, Embree 3.13.5).
const _: () = {
    assert!(size_of::<RTCRay>() == 48 && align_of::<RTCRay>() == 16);
    assert!(size_of::<RTCHit>() == 32 && align_of::<RTCHit>() == 16);
    assert!(offset_of!(RTCHit, u) == 12);
    assert!(offset_of!(RTCHit, prim_id) == 20);
    assert!(offset_of!(RTCHit, geom_id) == 24);
    assert!(offset_of!(RTCHit, inst_id) == 28);
    assert!(size_of::<RTCRayHit>() == 80 && align_of::<RTCRayHit>() == 16);
    assert!(offset_of!(RTCRayHit, hit) == 48);
    assert!(size_of::<RTCRay8>() == 384 && align_of::<RTCRay8>() == 32);
    assert!(size_of::<RTCHit8>() == 256 && align_of::<RTCHit8>() == 32);
    assert!(size_of::<RTCRayHit8>() == 640 && align_of::<RTCRayHit8>() == 32);
    assert!(offset_of!(RTCRayHit8, hit) == 384);
    assert!(size_of::<Valid8>() == 32 && align_of::<Valid8>() == 32);
    assert!(size_of::<RTCIntersectContext>() == 24 && align_of::<RTCIntersectContext>() == 8);
    assert!(offset_of!(RTCIntersectContext, filter) == 8);
    assert!(offset_of!(RTCIntersectContext, inst_id) == 16);
};

// Linked by build.rs (`-l embree3`) when the `embree` feature is on.
unsafe extern "C" {
    pub fn rtcNewDevice(config: *const c_char) -> RTCDevice;
    pub fn rtcReleaseDevice(device: RTCDevice);
    pub fn rtcGetDeviceError(device: RTCDevice) -> RTCError;
    pub fn rtcGetDeviceProperty(device: RTCDevice, prop: RTCDeviceProperty) -> isize;

    pub fn rtcNewScene(device: RTCDevice) -> RTCScene;
    pub fn rtcReleaseScene(scene: RTCScene);
    pub fn rtcSetSceneBuildQuality(scene: RTCScene, quality: RTCBuildQuality);
    pub fn rtcAttachGeometry(scene: RTCScene, geometry: RTCGeometry) -> c_uint;
    pub fn rtcCommitScene(scene: RTCScene);

    pub fn rtcNewGeometry(device: RTCDevice, kind: RTCGeometryType) -> RTCGeometry;
    pub fn rtcReleaseGeometry(geometry: RTCGeometry);
    pub fn rtcSetNewGeometryBuffer(
        geometry: RTCGeometry,
        kind: RTCBufferType,
        slot: c_uint,
        format: RTCFormat,
        byte_stride: usize,
        item_count: usize,
    ) -> *mut c_void;
    pub fn rtcCommitGeometry(geometry: RTCGeometry);

    pub fn rtcIntersect1(
        scene: RTCScene,
        context: *mut RTCIntersectContext,
        rayhit: *mut RTCRayHit,
    );
    pub fn rtcIntersect1M(
        scene: RTCScene,
        context: *mut RTCIntersectContext,
        rayhit: *mut RTCRayHit,
        m: c_uint,
        byte_stride: usize,
    );
    pub fn rtcIntersect8(
        valid: *const c_int,
        scene: RTCScene,
        context: *mut RTCIntersectContext,
        rayhit: *mut RTCRayHit8,
    );
}
