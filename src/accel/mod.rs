//! The safe layer over Embree: the only module of the renderer that may use `unsafe`.
//!
//! - [`Device`] owns an `RTCDevice` and turns Embree's error callback into [`EmbreeError`].
//! - [`SceneBuilder`] attaches triangle meshes; [`SceneBuilder::commit`] gives an immutable
//!   [`Scene`] that is `Send + Sync` (Embree queries are thread-safe after a commit).
//! - Queries: [`Scene::intersect1`], [`Scene::occluded1`], and the 4-wide packet queries
//!   [`Scene::intersect4`] / [`Scene::occluded4`] over a [`RayHit4`] in Embree's own
//!   structure-of-arrays layout, with an active-lane mask and a [`Coherence`] hint.
//!
//! Both Embree 3 (`RTCIntersectContext`) and Embree 4 (`RTCIntersectArguments`) are
//! supported; `build.rs` sets the cfg `embree3` or `embree4` from what `embree-sys` found.
//!
//! Rays Embree cannot trace (see [`Ray::is_traceable`]: NaN or huge origins and
//! directions, a negative or NaN `tnear`, a NaN `tfar`) never reach Embree: they are
//! misses. Debian's Embree 3.13.5 is built with assertions and aborts the process on them.
#![allow(unsafe_code)]

use embree_sys as sys;
use glam::Vec3;
use std::ffi::{c_char, c_void, CStr};
use std::fmt;
use std::sync::{Arc, Mutex};

/// An error reported by Embree through its error callback (or by a null handle).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct EmbreeError {
    /// Embree's `RTCError` code.
    pub code: u32,
    /// Embree's message (or a description of the call that failed).
    pub message: String,
}

impl EmbreeError {
    fn code_name(&self) -> &'static str {
        match self.code {
            sys::RTC_ERROR_NONE => "RTC_ERROR_NONE",
            sys::RTC_ERROR_UNKNOWN => "RTC_ERROR_UNKNOWN",
            sys::RTC_ERROR_INVALID_ARGUMENT => "RTC_ERROR_INVALID_ARGUMENT",
            sys::RTC_ERROR_INVALID_OPERATION => "RTC_ERROR_INVALID_OPERATION",
            sys::RTC_ERROR_OUT_OF_MEMORY => "RTC_ERROR_OUT_OF_MEMORY",
            sys::RTC_ERROR_UNSUPPORTED_CPU => "RTC_ERROR_UNSUPPORTED_CPU",
            sys::RTC_ERROR_CANCELLED => "RTC_ERROR_CANCELLED",
            _ => "RTC_ERROR_?",
        }
    }
}

impl fmt::Display for EmbreeError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "Embree error {} ({}): {}",
            self.code_name(),
            self.code,
            self.message
        )
    }
}

impl std::error::Error for EmbreeError {}

/// The environment variable whose value [`Device::new`] hands to `rtcNewDevice`.
pub const CONFIG_VARIABLE: &str = "STOKES_EMBREE_CONFIG";

/// The kernel names that both Embree 3 and 4 accept for `isa=` and `max_isa=`, with the
/// CPU feature each needs. Embree 3.13 silently falls back to SSE2 for any other name (and
/// an `isa=` the CPU lacks would select kernels that crash on their first instruction),
/// so these keys are checked here rather than left to Embree.
pub const ISAS: [(&str, &str); 5] = [
    ("sse2", "sse2"),
    ("sse4.2", "sse4.2"),
    ("avx", "avx"),
    ("avx2", "avx2"),
    ("avx512", "avx512f"),
];

/// Whether this CPU can run Embree's kernels for `isa` (one of [`ISAS`]).
pub fn cpu_has_isa(isa: &str) -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        match isa {
            "sse2" => std::arch::is_x86_feature_detected!("sse2"),
            "sse4.2" => std::arch::is_x86_feature_detected!("sse4.2"),
            "avx" => std::arch::is_x86_feature_detected!("avx"),
            "avx2" => {
                std::arch::is_x86_feature_detected!("avx2")
                    && std::arch::is_x86_feature_detected!("fma")
            }
            "avx512" => {
                std::arch::is_x86_feature_detected!("avx512f")
                    && std::arch::is_x86_feature_detected!("avx512dq")
                    && std::arch::is_x86_feature_detected!("avx512cd")
                    && std::arch::is_x86_feature_detected!("avx512bw")
                    && std::arch::is_x86_feature_detected!("avx512vl")
            }
            _ => false,
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        let _ = isa;
        false
    }
}

/// Checks the `isa=` and `max_isa=` entries of an Embree configuration string (entries are
/// separated by commas or white space): the name must be one of [`ISAS`], and for `isa=`
/// the CPU must have it. Everything else is left to Embree's own parser.
pub fn check_config(config: &str) -> Result<(), EmbreeError> {
    let invalid = |message: String| EmbreeError {
        code: sys::RTC_ERROR_INVALID_ARGUMENT,
        message,
    };
    for entry in config
        .split([',', ' ', '\t', '\n'])
        .filter(|e| !e.is_empty())
    {
        let Some((key, value)) = entry.split_once('=') else {
            continue;
        };
        let (key, value) = (key.trim(), value.trim());
        if key != "isa" && key != "max_isa" {
            continue;
        }
        let names: Vec<&str> = ISAS.iter().map(|(n, _)| *n).collect();
        if !names.contains(&value) {
            return Err(invalid(format!(
                "{key}: expected one of {}, found {value:?}",
                names.join(", ")
            )));
        }
        if key == "isa" && !cpu_has_isa(value) {
            let have: Vec<&str> = names.iter().copied().filter(|n| cpu_has_isa(n)).collect();
            return Err(invalid(format!(
                "isa: this CPU cannot run {value} kernels (it has {})",
                have.join(", ")
            )));
        }
    }
    Ok(())
}

/// Where the error callback leaves the first error since the last check.
type ErrorSlot = Mutex<Option<EmbreeError>>;

unsafe extern "C" fn error_callback(user: *mut c_void, code: sys::RTCError, msg: *const c_char) {
    // SAFETY: `user` is the `ErrorSlot` boxed inside `DeviceInner`, which outlives the
    // device (it is dropped after `rtcReleaseDevice`). `msg` is a NUL-terminated string
    // owned by Embree for the duration of the call, or null.
    let slot = unsafe { &*(user as *const ErrorSlot) };
    let message = if msg.is_null() {
        String::from("(no message)")
    } else {
        // SAFETY: see above; Embree passes a valid C string.
        unsafe { CStr::from_ptr(msg) }
            .to_string_lossy()
            .into_owned()
    };
    if let Ok(mut s) = slot.lock() {
        if s.is_none() {
            *s = Some(EmbreeError { code, message });
        }
    }
}

struct DeviceInner {
    raw: sys::RTCDevice,
    errors: Box<ErrorSlot>,
}

// SAFETY: Embree devices are thread-safe handles; the error slot is behind a Mutex.
unsafe impl Send for DeviceInner {}
// SAFETY: as above.
unsafe impl Sync for DeviceInner {}

impl Drop for DeviceInner {
    fn drop(&mut self) {
        // SAFETY: `raw` was returned non-null by `rtcNewDevice` and is released once here.
        unsafe { sys::rtcReleaseDevice(self.raw) };
    }
}

/// An Embree device. Cloning shares the same device.
#[derive(Clone)]
pub struct Device {
    inner: Arc<DeviceInner>,
}

impl Device {
    /// A device with the configuration in the environment variable
    /// [`CONFIG_VARIABLE`] (`STOKES_EMBREE_CONFIG`, e.g. `isa=sse4.2` to force a kernel),
    /// or Embree's default configuration when it is unset or empty. A value that Embree or
    /// [`check_config`] rejects is an error naming the variable.
    pub fn new() -> Result<Device, EmbreeError> {
        let config = std::env::var(CONFIG_VARIABLE).unwrap_or_default();
        let named = |e: EmbreeError| EmbreeError {
            code: e.code,
            message: format!("{CONFIG_VARIABLE}={config:?}: {}", e.message),
        };
        check_config(&config).map_err(named)?;
        Device::with_config(&config).map_err(named)
    }

    /// A device with an Embree configuration string (for example `"threads=1"`).
    /// An invalid configuration is an error carrying Embree's code.
    pub fn with_config(config: &str) -> Result<Device, EmbreeError> {
        let cfg = std::ffi::CString::new(config).map_err(|_| EmbreeError {
            code: sys::RTC_ERROR_INVALID_ARGUMENT,
            message: "device configuration contains a NUL byte".into(),
        })?;
        // SAFETY: `cfg` is a valid NUL-terminated string for the duration of the call.
        let raw = unsafe { sys::rtcNewDevice(cfg.as_ptr()) };
        if raw.is_null() {
            // SAFETY: a null device asks for the error of the last failed device creation
            // on this thread, as documented for `rtcGetDeviceError`.
            let code = unsafe { sys::rtcGetDeviceError(std::ptr::null_mut()) };
            return Err(EmbreeError {
                code,
                message: format!("rtcNewDevice failed for configuration {config:?}"),
            });
        }
        let errors: Box<ErrorSlot> = Box::new(Mutex::new(None));
        let user = &*errors as *const ErrorSlot as *mut c_void;
        // SAFETY: `raw` is a live device; `user` points into a Box whose address is stable
        // and which lives as long as the device (see `DeviceInner`'s field order and Drop).
        unsafe { sys::rtcSetDeviceErrorFunction(raw, Some(error_callback), user) };
        Ok(Device {
            inner: Arc::new(DeviceInner { raw, errors }),
        })
    }

    /// Takes the first error Embree reported since the last check, if any.
    fn take_error(&self) -> Result<(), EmbreeError> {
        let mut slot = self.inner.errors.lock().unwrap_or_else(|e| e.into_inner());
        match slot.take() {
            Some(e) => Err(e),
            None => Ok(()),
        }
    }

    /// A new, empty scene on this device.
    pub fn scene_builder(&self) -> Result<SceneBuilder, EmbreeError> {
        // SAFETY: the device is live for as long as `self.inner` is.
        let raw = unsafe { sys::rtcNewScene(self.inner.raw) };
        self.take_error()?;
        if raw.is_null() {
            return Err(EmbreeError {
                code: sys::RTC_ERROR_UNKNOWN,
                message: "rtcNewScene returned null".into(),
            });
        }
        Ok(SceneBuilder {
            device: self.clone(),
            raw,
            triangles: 0,
            geometries: 0,
        })
    }
}

/// A scene being assembled. Not shareable until [`SceneBuilder::commit`].
pub struct SceneBuilder {
    device: Device,
    raw: sys::RTCScene,
    triangles: usize,
    geometries: u32,
}

impl Drop for SceneBuilder {
    fn drop(&mut self) {
        if !self.raw.is_null() {
            // SAFETY: `raw` came from `rtcNewScene` and has not been handed to a `Scene`.
            unsafe { sys::rtcReleaseScene(self.raw) };
        }
    }
}

/// Vertex data format of a triangle mesh handed to [`SceneBuilder::attach_triangles_with`];
/// only `Float3` is valid for triangles, the others exist so that tests can provoke
/// Embree's own validation.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum VertexFormat {
    /// Three `f32` per vertex.
    Float3,
    /// An undefined format: Embree rejects it.
    Undefined,
}

impl SceneBuilder {
    /// Attaches a triangle mesh and returns its geometry id (ids count up from 0 in the
    /// order meshes are attached). Vertex and index data are copied into Embree-owned,
    /// padded buffers once; nothing else keeps a copy.
    pub fn attach_triangles(
        &mut self,
        vertices: &[[f32; 3]],
        indices: &[[u32; 3]],
    ) -> Result<u32, EmbreeError> {
        self.attach_triangles_with(vertices, indices, VertexFormat::Float3)
    }

    /// [`SceneBuilder::attach_triangles`] with an explicit vertex format.
    pub fn attach_triangles_with(
        &mut self,
        vertices: &[[f32; 3]],
        indices: &[[u32; 3]],
        format: VertexFormat,
    ) -> Result<u32, EmbreeError> {
        let nv = vertices.len() as u32;
        if let Some((i, tri)) = indices
            .iter()
            .enumerate()
            .find(|(_, t)| t.iter().any(|&k| k >= nv))
        {
            return Err(EmbreeError {
                code: sys::RTC_ERROR_INVALID_ARGUMENT,
                message: format!(
                    "triangle {i} has vertex index {tri:?} out of range (mesh has {nv} vertices)"
                ),
            });
        }
        let dev = self.device.inner.raw;
        // SAFETY: `dev` is live; the geometry is released below on every path after use.
        let geom = unsafe { sys::rtcNewGeometry(dev, sys::RTC_GEOMETRY_TYPE_TRIANGLE) };
        self.device.take_error()?;
        let fmt = match format {
            VertexFormat::Float3 => sys::RTC_FORMAT_FLOAT3,
            VertexFormat::Undefined => sys::RTC_FORMAT_UNDEFINED,
        };
        let result = (|| {
            // SAFETY: `geom` is a live geometry; Embree allocates a buffer of `nv` items
            // of 12 bytes (with its own padding) and returns a pointer to it or null.
            let vb = unsafe {
                sys::rtcSetNewGeometryBuffer(
                    geom,
                    sys::RTC_BUFFER_TYPE_VERTEX,
                    0,
                    fmt,
                    12,
                    nv as usize,
                )
            } as *mut [f32; 3];
            self.device.take_error()?;
            if !vb.is_null() && nv > 0 {
                // SAFETY: `vb` points to at least `nv` writable, 4-byte aligned [f32; 3]
                // slots allocated by Embree above; the source slice has exactly `nv` items.
                unsafe { std::ptr::copy_nonoverlapping(vertices.as_ptr(), vb, vertices.len()) };
            }
            let nt = indices.len();
            // SAFETY: as for the vertex buffer, with `nt` items of three u32.
            let ib = unsafe {
                sys::rtcSetNewGeometryBuffer(
                    geom,
                    sys::RTC_BUFFER_TYPE_INDEX,
                    0,
                    sys::RTC_FORMAT_UINT3,
                    12,
                    nt,
                )
            } as *mut [u32; 3];
            self.device.take_error()?;
            if !ib.is_null() && nt > 0 {
                // SAFETY: `ib` holds `nt` writable [u32; 3] slots; the source has `nt` items.
                unsafe { std::ptr::copy_nonoverlapping(indices.as_ptr(), ib, nt) };
            }
            // SAFETY: `geom` is live and its buffers are set.
            unsafe { sys::rtcCommitGeometry(geom) };
            self.device.take_error()?;
            // SAFETY: `self.raw` and `geom` are live; the scene retains the geometry.
            let id = unsafe { sys::rtcAttachGeometry(self.raw, geom) };
            self.device.take_error()?;
            Ok(id)
        })();
        // SAFETY: drop our reference; the scene holds its own if attaching succeeded.
        unsafe { sys::rtcReleaseGeometry(geom) };
        let id = result?;
        self.triangles += indices.len();
        self.geometries += 1;
        Ok(id)
    }

    /// Builds the BVH. The result is immutable and can be shared across threads.
    pub fn commit(mut self) -> Result<Scene, EmbreeError> {
        // SAFETY: `self.raw` is a live scene; committing is the documented final step.
        unsafe { sys::rtcCommitScene(self.raw) };
        self.device.take_error()?;
        let raw = std::mem::replace(&mut self.raw, std::ptr::null_mut());
        Ok(Scene {
            device: self.device.clone(),
            raw,
            triangles: self.triangles,
            geometries: self.geometries,
        })
    }
}

/// A committed Embree scene: immutable, `Send + Sync`.
pub struct Scene {
    device: Device,
    raw: sys::RTCScene,
    triangles: usize,
    geometries: u32,
}

// SAFETY: after `rtcCommitScene`, Embree documents all query functions as thread-safe, and
// `Scene` exposes no mutation.
unsafe impl Send for Scene {}
// SAFETY: as above.
unsafe impl Sync for Scene {}

impl Drop for Scene {
    fn drop(&mut self) {
        // SAFETY: `raw` is the committed scene this value owns; released once.
        unsafe { sys::rtcReleaseScene(self.raw) };
        let _ = &self.device; // the device outlives the scene (dropped after this)
    }
}

/// A ray segment `org + t·dir` for `t` in `[tnear, tfar]`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ray {
    /// Origin.
    pub org: Vec3,
    /// Direction (need not be normalised; `t` is in units of its length).
    pub dir: Vec3,
    /// Start of the segment.
    pub tnear: f32,
    /// End of the segment.
    pub tfar: f32,
}

impl Ray {
    /// A ray over `[0, ∞)`.
    pub fn new(org: Vec3, dir: Vec3) -> Ray {
        Ray {
            org,
            dir,
            tnear: 0.0,
            tfar: f32::INFINITY,
        }
    }

    /// Whether Embree accepts the ray: every component of `org` and `dir` within
    /// ±1.844·10¹⁸ (Embree's `FLT_LARGE`; so not NaN or infinite), `tnear ≥ 0`, `tfar` not
    /// NaN. The queries report any other ray as a miss (not occluded) without calling
    /// Embree, whose ray-validity assertions abort the process in Debian's build.
    #[inline]
    pub fn is_traceable(&self) -> bool {
        let (o, d) = (self.org, self.dir);
        traceable([o.x, o.y, o.z], [d.x, d.y, d.z], self.tnear, self.tfar)
    }
}

/// Embree's `FLT_LARGE` (common/math/constants.h): `RayK::valid()` wants every origin and
/// direction component within ±this.
pub const FLT_LARGE: f32 = 1.844e18;

/// Embree's `RayK::valid()` plus its `tnear >= 0` assertion, for one ray.
#[inline]
fn traceable(org: [f32; 3], dir: [f32; 3], tnear: f32, tfar: f32) -> bool {
    // `abs(x) <= FLT_LARGE` is false for NaN and ±∞; `&` keeps it branch-free.
    let ok = |x: f32| x.abs() <= FLT_LARGE;
    let segment = (tnear >= 0.0) & !tfar.is_nan();
    ok(org[0]) & ok(org[1]) & ok(org[2]) & ok(dir[0]) & ok(dir[1]) & ok(dir[2]) & segment
}

/// The closest hit along a ray.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Hit {
    /// Distance along the ray (in units of `dir`).
    pub t: f32,
    /// Geometry id (the order meshes were attached in).
    pub geom_id: u32,
    /// Triangle index within the mesh.
    pub prim_id: u32,
    /// Barycentric coordinate of vertex 1.
    pub u: f32,
    /// Barycentric coordinate of vertex 2.
    pub v: f32,
    /// Unnormalised geometric normal, `(v1 − v0) × (v2 − v0)`.
    pub ng: Vec3,
}

/// How coherent the rays of a query are; Embree traverses differently for each. Coherent
/// is right for camera rays and for shadow rays from a 2×2 pixel quad; it halves the rate
/// of incoherent packets, so secondary rays must say `Incoherent`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Coherence {
    /// Rays of the packet start close together and point in similar directions.
    Coherent,
    /// Anything else.
    Incoherent,
}

/// A packet of four rays and their hits in Embree's SoA layout (16-byte aligned), so that
/// the renderer can fill it straight from its 4-wide vectors.
#[repr(transparent)]
#[derive(Clone, Copy, Default)]
pub struct RayHit4(sys::RTCRayHit4);

const _: () = assert!(std::mem::align_of::<RayHit4>() >= 16);

impl RayHit4 {
    /// An empty packet.
    pub fn new() -> RayHit4 {
        let mut p = RayHit4::default();
        p.0.ray.mask = [u32::MAX; 4];
        p.0.hit.geomID = [sys::RTC_INVALID_GEOMETRY_ID; 4];
        p
    }

    /// Sets lane `k`'s ray and clears its hit.
    #[inline]
    pub fn set_ray(&mut self, k: usize, ray: &Ray) {
        let r = &mut self.0.ray;
        r.org_x[k] = ray.org.x;
        r.org_y[k] = ray.org.y;
        r.org_z[k] = ray.org.z;
        r.dir_x[k] = ray.dir.x;
        r.dir_y[k] = ray.dir.y;
        r.dir_z[k] = ray.dir.z;
        r.tnear[k] = ray.tnear;
        r.tfar[k] = ray.tfar;
        r.time[k] = 0.0;
        r.mask[k] = u32::MAX;
        r.flags[k] = 0;
        r.id[k] = k as u32;
        self.0.hit.geomID[k] = sys::RTC_INVALID_GEOMETRY_ID;
    }

    /// Lane `k`'s ray (its `tfar` is the hit distance after a query that hit).
    #[inline]
    pub fn ray(&self, k: usize) -> Ray {
        let r = &self.0.ray;
        Ray {
            org: Vec3::new(r.org_x[k], r.org_y[k], r.org_z[k]),
            dir: Vec3::new(r.dir_x[k], r.dir_y[k], r.dir_z[k]),
            tnear: r.tnear[k],
            tfar: r.tfar[k],
        }
    }

    /// Lane `k`'s hit after [`Scene::intersect4`], or `None` for a miss.
    #[inline]
    pub fn hit(&self, k: usize) -> Option<Hit> {
        let h = &self.0.hit;
        if h.geomID[k] == sys::RTC_INVALID_GEOMETRY_ID {
            return None;
        }
        Some(Hit {
            t: self.0.ray.tfar[k],
            geom_id: h.geomID[k],
            prim_id: h.primID[k],
            u: h.u[k],
            v: h.v[k],
            ng: Vec3::new(h.Ng_x[k], h.Ng_y[k], h.Ng_z[k]),
        })
    }

    /// Lane `k` after [`Scene::occluded4`]: Embree sets `tfar` to −∞ for an occluded ray.
    #[inline]
    pub fn occluded(&self, k: usize) -> bool {
        self.0.ray.tfar[k] == f32::NEG_INFINITY
    }

    /// `active` with the lanes whose rays Embree cannot trace switched off.
    #[inline]
    fn traceable(&self, active: [bool; 4]) -> [bool; 4] {
        let r = &self.0.ray;
        std::array::from_fn(|k| {
            active[k]
                & traceable(
                    [r.org_x[k], r.org_y[k], r.org_z[k]],
                    [r.dir_x[k], r.dir_y[k], r.dir_z[k]],
                    r.tnear[k],
                    r.tfar[k],
                )
        })
    }
}

/// N rays in structure-of-arrays form, as the estimator holds them: origins and
/// directions per coordinate, `t` in `[0, tfar]` (`Rays4`, `Rays8` for the packet queries).
#[derive(Debug, Clone, Copy)]
pub struct RaysN<const N: usize> {
    /// Origins: x, y and z of the N rays.
    pub org: [[f32; N]; 3],
    /// Directions.
    pub dir: [[f32; N]; 3],
    /// Segment ends.
    pub tfar: [f32; N],
}

impl<const N: usize> RaysN<N> {
    /// Ray `k`'s origin.
    #[inline]
    fn origin(&self, k: usize) -> [f32; 3] {
        [self.org[0][k], self.org[1][k], self.org[2][k]]
    }

    /// Ray `k`'s direction.
    #[inline]
    fn direction(&self, k: usize) -> [f32; 3] {
        [self.dir[0][k], self.dir[1][k], self.dir[2][k]]
    }
}

/// Four rays for `intersect4`/`occluded4`.
pub type Rays4 = RaysN<4>;
/// Eight rays for `intersect8`/`occluded8`.
pub type Rays8 = RaysN<8>;

impl<const N: usize> Default for RaysN<N> {
    fn default() -> RaysN<N> {
        RaysN {
            org: [[0.0; N]; 3],
            dir: [[0.0; N]; 3],
            tfar: [0.0; N],
        }
    }
}

impl<const N: usize> RaysN<N> {
    /// The first N of `rays` (their `tnear` taken as 0), and the lanes that hold one.
    pub fn from_rays(rays: &[Ray]) -> (RaysN<N>, [bool; N]) {
        let mut soa = RaysN::default();
        let mut active = [false; N];
        for (k, r) in rays.iter().take(N).enumerate() {
            for d in 0..3 {
                soa.org[d][k] = r.org[d];
                soa.dir[d][k] = r.dir[d];
            }
            soa.tfar[k] = r.tfar;
            active[k] = true;
        }
        (soa, active)
    }
}

/// The closest hits of N rays in structure-of-arrays form; `geom[k]` is `u32::MAX`
/// where ray k hit nothing (the other fields are then meaningless).
#[derive(Debug, Clone, Copy)]
pub struct HitsN<const N: usize> {
    /// Distances along the rays.
    pub t: [f32; N],
    /// Unnormalised geometric normals, per coordinate.
    pub ng: [[f32; N]; 3],
    /// Geometry ids.
    pub geom: [u32; N],
    /// Triangle indices.
    pub prim: [u32; N],
    /// Barycentric coordinates of vertex 1 (Embree's `u`).
    pub u: [f32; N],
    /// Barycentric coordinates of vertex 2 (Embree's `v`).
    pub v: [f32; N],
}

impl<const N: usize> HitsN<N> {
    /// Ray `k`'s hit, or `None` for a miss.
    #[inline]
    pub fn hit(&self, k: usize) -> Option<Hit> {
        (self.geom[k] != sys::RTC_INVALID_GEOMETRY_ID).then(|| Hit {
            t: self.t[k],
            geom_id: self.geom[k],
            prim_id: self.prim[k],
            u: self.u[k],
            v: self.v[k],
            ng: Vec3::new(self.ng[0][k], self.ng[1][k], self.ng[2][k]),
        })
    }
}

/// The hits of a 4-wide packet.
pub type Hits4 = HitsN<4>;
/// The hits of an 8-wide packet.
pub type Hits8 = HitsN<8>;

impl RayHit4 {
    /// A packet holding `rays`, hits cleared.
    #[inline]
    fn from_soa(rays: &Rays4) -> RayHit4 {
        let mut p = RayHit4::new();
        let r = &mut p.0.ray;
        [r.org_x, r.org_y, r.org_z] = rays.org;
        [r.dir_x, r.dir_y, r.dir_z] = rays.dir;
        r.tfar = rays.tfar;
        r.id = [0, 1, 2, 3];
        p
    }
}

/// The `valid` argument of the packet queries: −1 marks an active lane. Must be 16-byte
/// aligned.
#[repr(C, align(16))]
struct Valid4([i32; 4]);

impl Valid4 {
    fn from_mask(active: [bool; 4]) -> Valid4 {
        Valid4(active.map(|a| if a { -1 } else { 0 }))
    }
}

#[cfg(embree3)]
mod query {
    //! Embree 3: queries take an `RTCIntersectContext` (the `rtcInitIntersectContext`
    //! helper is inline in the header, so it is rebuilt here).
    use super::{sys, Coherence};

    pub struct Ctx(pub sys::RTCIntersectContext);

    impl Ctx {
        #[inline]
        pub fn new(c: Coherence) -> Ctx {
            Ctx(sys::RTCIntersectContext {
                flags: match c {
                    Coherence::Coherent => sys::RTC_INTERSECT_CONTEXT_FLAG_COHERENT,
                    Coherence::Incoherent => sys::RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT,
                },
                filter: None,
                instID: [sys::RTC_INVALID_GEOMETRY_ID; 1],
            })
        }
    }
}

#[cfg(embree4)]
mod query {
    //! Embree 4: queries take optional `RTCIntersectArguments` / `RTCOccludedArguments`
    //! (the `rtcInit*Arguments` helpers are inline in the header, so they are rebuilt here).
    use super::{sys, Coherence};

    fn flags(c: Coherence) -> sys::RTCRayQueryFlags {
        match c {
            Coherence::Coherent => sys::RTC_RAY_QUERY_FLAG_COHERENT,
            Coherence::Incoherent => sys::RTC_RAY_QUERY_FLAG_INCOHERENT,
        }
    }

    pub fn intersect_args(c: Coherence) -> sys::RTCIntersectArguments {
        let mut a = sys::RTCIntersectArguments::default();
        a.flags = flags(c);
        a.feature_mask = sys::RTC_FEATURE_FLAG_ALL;
        a.context = std::ptr::null_mut();
        a.filter = None;
        a.intersect = None;
        a
    }

    pub fn occluded_args(c: Coherence) -> sys::RTCOccludedArguments {
        let mut a = sys::RTCOccludedArguments::default();
        a.flags = flags(c);
        a.feature_mask = sys::RTC_FEATURE_FLAG_ALL;
        a.context = std::ptr::null_mut();
        a.filter = None;
        a.occluded = None;
        a
    }
}

fn to_rtc_ray(ray: &Ray) -> sys::RTCRay {
    sys::RTCRay {
        org_x: ray.org.x,
        org_y: ray.org.y,
        org_z: ray.org.z,
        tnear: ray.tnear,
        dir_x: ray.dir.x,
        dir_y: ray.dir.y,
        dir_z: ray.dir.z,
        time: 0.0,
        tfar: ray.tfar,
        mask: u32::MAX,
        id: 0,
        flags: 0,
    }
}

impl Scene {
    /// Number of triangles over all meshes.
    pub fn triangle_count(&self) -> usize {
        self.triangles
    }

    /// Number of attached meshes.
    pub fn geometry_count(&self) -> u32 {
        self.geometries
    }

    /// The closest hit along `ray`, if any (`None` for a ray that is not
    /// [traceable](Ray::is_traceable)).
    #[inline]
    pub fn intersect1(&self, ray: &Ray) -> Option<Hit> {
        if !ray.is_traceable() {
            return None;
        }
        let mut rh = sys::RTCRayHit {
            ray: to_rtc_ray(ray),
            hit: sys::RTCHit {
                geomID: sys::RTC_INVALID_GEOMETRY_ID,
                ..Default::default()
            },
        };
        #[cfg(embree3)]
        {
            let mut ctx = query::Ctx::new(Coherence::Incoherent);
            // SAFETY: the scene is committed; `ctx` and `rh` are valid for the call.
            unsafe { sys::rtcIntersect1(self.raw, &mut ctx.0, &mut rh) };
        }
        #[cfg(embree4)]
        {
            let mut args = query::intersect_args(Coherence::Incoherent);
            // SAFETY: the scene is committed; `args` and `rh` are valid for the call.
            unsafe { sys::rtcIntersect1(self.raw, &mut rh, &mut args) };
        }
        if rh.hit.geomID == sys::RTC_INVALID_GEOMETRY_ID {
            return None;
        }
        Some(Hit {
            t: rh.ray.tfar,
            geom_id: rh.hit.geomID,
            prim_id: rh.hit.primID,
            u: rh.hit.u,
            v: rh.hit.v,
            ng: Vec3::new(rh.hit.Ng_x, rh.hit.Ng_y, rh.hit.Ng_z),
        })
    }

    /// Whether anything blocks `ray` within `[tnear, tfar]` (`false` for a ray that is not
    /// [traceable](Ray::is_traceable)).
    #[inline]
    pub fn occluded1(&self, ray: &Ray) -> bool {
        if !ray.is_traceable() {
            return false;
        }
        let mut r = to_rtc_ray(ray);
        #[cfg(embree3)]
        {
            let mut ctx = query::Ctx::new(Coherence::Incoherent);
            // SAFETY: the scene is committed; `ctx` and `r` are valid for the call.
            unsafe { sys::rtcOccluded1(self.raw, &mut ctx.0, &mut r) };
        }
        #[cfg(embree4)]
        {
            let mut args = query::occluded_args(Coherence::Incoherent);
            // SAFETY: the scene is committed; `args` and `r` are valid for the call.
            unsafe { sys::rtcOccluded1(self.raw, &mut r, &mut args) };
        }
        r.tfar == f32::NEG_INFINITY
    }

    /// Closest hits for the active lanes of a packet; inactive lanes, and lanes whose ray
    /// is not [traceable](Ray::is_traceable), are left untouched.
    #[inline]
    pub fn intersect4(&self, packet: &mut RayHit4, active: [bool; 4], coherence: Coherence) {
        let valid = Valid4::from_mask(packet.traceable(active));
        #[cfg(embree3)]
        {
            let mut ctx = query::Ctx::new(coherence);
            // SAFETY: the scene is committed; `valid` and `packet` are 16-byte aligned
            // (checked by their types) and valid for the call.
            unsafe { sys::rtcIntersect4(valid.0.as_ptr(), self.raw, &mut ctx.0, &mut packet.0) };
        }
        #[cfg(embree4)]
        {
            let mut args = query::intersect_args(coherence);
            // SAFETY: as above, with Embree 4's argument struct.
            unsafe { sys::rtcIntersect4(valid.0.as_ptr(), self.raw, &mut packet.0, &mut args) };
        }
    }

    /// Occlusion for the active lanes of a packet (read with [`RayHit4::occluded`]);
    /// inactive lanes, and lanes whose ray is not [traceable](Ray::is_traceable), are left
    /// untouched.
    #[inline]
    pub fn occluded4(&self, packet: &mut RayHit4, active: [bool; 4], coherence: Coherence) {
        let valid = Valid4::from_mask(packet.traceable(active));
        #[cfg(embree3)]
        {
            let mut ctx = query::Ctx::new(coherence);
            // SAFETY: the scene is committed; `valid` and the ray part of `packet` are
            // 16-byte aligned and valid for the call.
            unsafe { sys::rtcOccluded4(valid.0.as_ptr(), self.raw, &mut ctx.0, &mut packet.0.ray) };
        }
        #[cfg(embree4)]
        {
            let mut args = query::occluded_args(coherence);
            // SAFETY: as above, with Embree 4's argument struct.
            unsafe { sys::rtcOccluded4(valid.0.as_ptr(), self.raw, &mut packet.0.ray, &mut args) };
        }
    }
}

impl Scene {
    /// [`Scene::intersect4`] on rays in structure-of-arrays form.
    #[inline]
    pub fn intersect4_soa(&self, rays: &Rays4, active: [bool; 4], coherence: Coherence) -> Hits4 {
        let mut packet = RayHit4::from_soa(rays);
        self.intersect4(&mut packet, active, coherence);
        let h = &packet.0.hit;
        Hits4 {
            t: packet.0.ray.tfar,
            ng: [h.Ng_x, h.Ng_y, h.Ng_z],
            geom: std::array::from_fn(|k| if active[k] { h.geomID[k] } else { u32::MAX }),
            prim: h.primID,
            u: h.u,
            v: h.v,
        }
    }

    /// [`Scene::occluded4`] on rays in structure-of-arrays form: which active rays are
    /// blocked.
    #[inline]
    pub fn occluded4_soa(
        &self,
        rays: &Rays4,
        active: [bool; 4],
        coherence: Coherence,
    ) -> [bool; 4] {
        let mut packet = RayHit4::from_soa(rays);
        self.occluded4(&mut packet, active, coherence);
        std::array::from_fn(|k| active[k] && packet.occluded(k))
    }
}

/// Embree's 8-wide ray-hit packet, 32-byte aligned as `rtcIntersect8` requires.
#[repr(C, align(32))]
#[derive(Clone, Copy, Default)]
struct RayHit8(sys::RTCRayHit8);

/// The `valid` argument of the 8-wide queries (32-byte aligned).
#[repr(C, align(32))]
struct Valid8([i32; 8]);

impl RayHit8 {
    /// A packet holding the traceable rays of `rays` among `active`, hits cleared, and
    /// its `valid` mask.
    fn from_soa(rays: &Rays8, active: [bool; 8]) -> (RayHit8, Valid8) {
        let mut p = RayHit8::default();
        let r = &mut p.0.ray;
        [r.org_x, r.org_y, r.org_z] = rays.org;
        [r.dir_x, r.dir_y, r.dir_z] = rays.dir;
        r.tfar = rays.tfar;
        r.mask = [u32::MAX; 8];
        r.id = [0, 1, 2, 3, 4, 5, 6, 7];
        p.0.hit.geomID = [sys::RTC_INVALID_GEOMETRY_ID; 8];
        let valid = Valid8(std::array::from_fn(|k| {
            let ok = active[k] && traceable(rays.origin(k), rays.direction(k), 0.0, rays.tfar[k]);
            if ok {
                -1
            } else {
                0
            }
        }));
        (p, valid)
    }
}

impl Scene {
    /// Closest hits of the active lanes of eight rays (`rtcIntersect8`).
    #[inline]
    pub fn intersect8_soa(&self, rays: &Rays8, active: [bool; 8], coherence: Coherence) -> Hits8 {
        let (mut p, valid) = RayHit8::from_soa(rays, active);
        #[cfg(embree3)]
        {
            let mut ctx = query::Ctx::new(coherence);
            // SAFETY: the scene is committed; `valid` and `p` are 32-byte aligned (their
            // types say so) and valid for the call.
            unsafe { sys::rtcIntersect8(valid.0.as_ptr(), self.raw, &mut ctx.0, &mut p.0) };
        }
        #[cfg(embree4)]
        {
            let mut args = query::intersect_args(coherence);
            // SAFETY: as above, with Embree 4's argument struct.
            unsafe { sys::rtcIntersect8(valid.0.as_ptr(), self.raw, &mut p.0, &mut args) };
        }
        let h = &p.0.hit;
        Hits8 {
            t: p.0.ray.tfar,
            ng: [h.Ng_x, h.Ng_y, h.Ng_z],
            geom: std::array::from_fn(|k| {
                if valid.0[k] != 0 {
                    h.geomID[k]
                } else {
                    u32::MAX
                }
            }),
            prim: h.primID,
            u: h.u,
            v: h.v,
        }
    }

    /// Which active lanes of eight rays are blocked (`rtcOccluded8`).
    #[inline]
    pub fn occluded8_soa(
        &self,
        rays: &Rays8,
        active: [bool; 8],
        coherence: Coherence,
    ) -> [bool; 8] {
        let (mut p, valid) = RayHit8::from_soa(rays, active);
        #[cfg(embree3)]
        {
            let mut ctx = query::Ctx::new(coherence);
            // SAFETY: the scene is committed; `valid` and the ray part of `p` are 32-byte
            // aligned and valid for the call.
            unsafe { sys::rtcOccluded8(valid.0.as_ptr(), self.raw, &mut ctx.0, &mut p.0.ray) };
        }
        #[cfg(embree4)]
        {
            let mut args = query::occluded_args(coherence);
            // SAFETY: as above, with Embree 4's argument struct.
            unsafe { sys::rtcOccluded8(valid.0.as_ptr(), self.raw, &mut p.0.ray, &mut args) };
        }
        std::array::from_fn(|k| valid.0[k] != 0 && p.0.ray.tfar[k] == f32::NEG_INFINITY)
    }
}

/// A stream of rays and their hits for Embree 3's stream query `rtcIntersect1M`, which
/// packs the rays into packets of its own: the benchmark of the renderer's Embree limit
/// replays closest-hit rays through one.
#[cfg(embree3)]
#[derive(Default)]
pub struct RayStream {
    rays: Vec<sys::RTCRayHit>,
}

#[cfg(embree3)]
impl RayStream {
    /// Replaces the stream's rays (untraceable ones become empty segments, which Embree
    /// reports as misses).
    pub fn fill(&mut self, rays: impl Iterator<Item = Ray>) {
        self.rays.clear();
        self.rays.extend(rays.map(|r| {
            let mut rtc = to_rtc_ray(&r);
            if !r.is_traceable() {
                rtc = to_rtc_ray(&Ray {
                    org: Vec3::ZERO,
                    dir: Vec3::Z,
                    tnear: 0.0,
                    tfar: -1.0,
                });
            }
            sys::RTCRayHit {
                ray: rtc,
                hit: sys::RTCHit {
                    geomID: sys::RTC_INVALID_GEOMETRY_ID,
                    ..Default::default()
                },
            }
        }));
    }

    /// How many rays the stream holds.
    pub fn len(&self) -> usize {
        self.rays.len()
    }

    /// Whether the stream is empty.
    pub fn is_empty(&self) -> bool {
        self.rays.is_empty()
    }

    /// How many rays hit something (after [`Scene::intersect_stream`]).
    pub fn count_hits(&self) -> usize {
        let hit = |r: &&sys::RTCRayHit| r.hit.geomID != sys::RTC_INVALID_GEOMETRY_ID;
        self.rays.iter().filter(hit).count()
    }
}

/// A stream of rays for occlusion queries: Embree 3 traces it with `rtcOccluded1M`, which
/// packs the rays into packets of its own; Embree 4, which no longer has stream queries,
/// ray by ray. Each ray is Embree's 48-byte `RTCRay` with no room for a hit, which an
/// occlusion query does not write: the renderer's shadow rays go through one, pushed
/// while each group's state is still in the cache.
#[derive(Default)]
pub struct OcclusionStream {
    rays: Vec<sys::RTCRay>,
}

impl OcclusionStream {
    /// Empties the stream, keeping its memory.
    pub fn clear(&mut self) {
        self.rays.clear();
    }

    /// Appends a ray (an untraceable one as an empty segment, which Embree reports as not
    /// blocked).
    #[inline]
    pub fn push(&mut self, ray: &Ray) {
        let empty = Ray {
            org: Vec3::ZERO,
            dir: Vec3::Z,
            tnear: 0.0,
            tfar: -1.0,
        };
        let traced = if ray.is_traceable() { ray } else { &empty };
        self.rays.push(to_rtc_ray(traced));
    }

    /// Appends a ray over `[0, tfar]` from its origin and direction as Embree stores them
    /// (the fourth components, `tnear` and the time, are 0), for a caller that checked
    /// it is traceable with every lane of its packet at once ([`FLT_LARGE`]; Debian's
    /// Embree aborts on any other ray).
    #[inline]
    pub fn push_traceable(&mut self, org: glam::Vec4, dir: glam::Vec4, tfar: f32) {
        debug_assert!(traceable(
            org.truncate().into(),
            dir.truncate().into(),
            org.w,
            tfar
        ));
        self.rays.push(sys::RTCRay {
            org_x: org.x,
            org_y: org.y,
            org_z: org.z,
            tnear: org.w,
            dir_x: dir.x,
            dir_y: dir.y,
            dir_z: dir.z,
            time: dir.w,
            tfar,
            mask: u32::MAX,
            id: 0,
            flags: 0,
        });
    }

    /// How many rays the stream holds.
    pub fn len(&self) -> usize {
        self.rays.len()
    }

    /// Whether the stream is empty.
    pub fn is_empty(&self) -> bool {
        self.rays.is_empty()
    }

    /// Whether ray `i` is blocked (after [`Scene::occluded_stream`]).
    #[inline]
    pub fn blocked(&self, i: usize) -> bool {
        self.rays[i].tfar == f32::NEG_INFINITY
    }

    /// How many rays are blocked (after [`Scene::occluded_stream`]).
    pub fn count_blocked(&self) -> usize {
        self.rays
            .iter()
            .filter(|r| r.tfar == f32::NEG_INFINITY)
            .count()
    }
}

#[cfg(embree3)]
impl Scene {
    /// Closest hits of every ray of the stream, `chunk` rays per `rtcIntersect1M` call.
    pub fn intersect_stream(&self, stream: &mut RayStream, chunk: usize, coherence: Coherence) {
        let stride = std::mem::size_of::<sys::RTCRayHit>();
        for part in stream.rays.chunks_mut(chunk.max(1)) {
            let mut ctx = query::Ctx::new(coherence);
            // SAFETY: the scene is committed; `part` holds `part.len()` consecutive,
            // initialised `RTCRayHit`s `stride` bytes apart, valid for the call.
            unsafe {
                sys::rtcIntersect1M(
                    self.raw,
                    &mut ctx.0,
                    part.as_mut_ptr(),
                    part.len() as u32,
                    stride,
                )
            };
        }
    }

    /// Occlusion of every ray of the stream, `chunk` rays per `rtcOccluded1M` call.
    pub fn occluded_stream(
        &self,
        stream: &mut OcclusionStream,
        chunk: usize,
        coherence: Coherence,
    ) {
        let stride = std::mem::size_of::<sys::RTCRay>();
        for part in stream.rays.chunks_mut(chunk.max(1)) {
            let mut ctx = query::Ctx::new(coherence);
            // SAFETY: the scene is committed; `part` holds `part.len()` consecutive,
            // initialised `RTCRay`s `stride` bytes apart, valid for the call; Embree
            // writes only their `tfar`.
            unsafe {
                sys::rtcOccluded1M(
                    self.raw,
                    &mut ctx.0,
                    part.as_mut_ptr(),
                    part.len() as u32,
                    stride,
                )
            };
        }
    }
}

#[cfg(embree4)]
impl Scene {
    /// Occlusion of every ray of the stream, one `rtcOccluded1` each (Embree 4 has no
    /// stream queries; `chunk` is Embree 3's).
    pub fn occluded_stream(
        &self,
        stream: &mut OcclusionStream,
        _chunk: usize,
        coherence: Coherence,
    ) {
        for r in stream.rays.iter_mut() {
            let mut args = query::occluded_args(coherence);
            // SAFETY: the scene is committed; `args` and the ray are valid for the call.
            unsafe { sys::rtcOccluded1(self.raw, r, &mut args) };
        }
    }
}

/// Up to N rays and their hits in structure-of-arrays form, for Embree 3's SoA stream
/// query (`rtcIntersectNp`): a tracer copies its W-wide packets in at consecutive
/// places and reads their hits back in the same form, so that nothing goes lane by lane.
/// Traced as coherent, Embree packs the stream into packets of its widest vectors and
/// traverses them together, faster than 4- or 8-wide packets for camera rays.
#[repr(C, align(64))]
pub struct PacketStream<const N: usize> {
    org: [[f32; N]; 3],
    dir: [[f32; N]; 3],
    tnear: [f32; N],
    tfar: [f32; N],
    time: [f32; N],
    mask: [u32; N],
    id: [u32; N],
    flags: [u32; N],
    ng: [[f32; N]; 3],
    u: [f32; N],
    v: [f32; N],
    prim: [u32; N],
    geom: [u32; N],
    inst: [u32; N],
    len: usize,
}

impl<const N: usize> Default for PacketStream<N> {
    fn default() -> PacketStream<N> {
        // Every array starts 16-byte aligned, as Embree asks, when N is a multiple of 4.
        const { assert!(N.is_multiple_of(4)) };
        PacketStream {
            org: [[0.0; N]; 3],
            dir: [[0.0; N]; 3],
            tnear: [0.0; N],
            tfar: [0.0; N],
            time: [0.0; N],
            mask: [u32::MAX; N],
            id: std::array::from_fn(|k| k as u32),
            flags: [0; N],
            ng: [[0.0; N]; 3],
            u: [0.0; N],
            v: [0.0; N],
            prim: [0; N],
            geom: [sys::RTC_INVALID_GEOMETRY_ID; N],
            inst: [sys::RTC_INVALID_GEOMETRY_ID; N],
            len: 0,
        }
    }
}

impl<const N: usize> PacketStream<N> {
    /// Empties the stream.
    pub fn clear(&mut self) {
        self.len = 0;
    }

    /// How many rays the stream holds (W for each packet pushed).
    pub fn len(&self) -> usize {
        self.len
    }

    /// Whether the stream is empty.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Appends a packet of W rays, of which those in `active` that Embree can trace are
    /// traced (the others get `tfar` = −∞ < `tnear`, which makes Embree skip them; every
    /// `tnear` is 0 from the start, and Embree does not write it);
    /// returns where the packet starts, for [`Self::hits`]. Panics if the stream is full.
    pub fn push<const W: usize>(&mut self, rays: &RaysN<W>, active: [bool; W]) -> usize {
        let mut checked = *rays;
        for (k, &active) in active.iter().enumerate() {
            let on = active && traceable(rays.origin(k), rays.direction(k), 0.0, rays.tfar[k]);
            checked.tfar[k] = if on { rays.tfar[k] } else { f32::NEG_INFINITY };
        }
        self.push_checked(&checked)
    }

    /// Appends a packet of W rays whose caller checked, for every lane at once, which
    /// Embree can trace: each lane's `tfar` is its segment's end, or −∞ (< `tnear`) for a
    /// lane Embree is to skip. Returns where the packet starts, for [`Self::hits`].
    /// Panics if the stream is full.
    #[inline]
    pub fn push_checked<const W: usize>(&mut self, rays: &RaysN<W>) -> usize {
        let at = self.len;
        let end = at + W;
        assert!(end <= N, "a stream of {N} rays cannot take {end}");
        for c in 0..3 {
            self.org[c][at..end].copy_from_slice(&rays.org[c]);
            self.dir[c][at..end].copy_from_slice(&rays.dir[c]);
        }
        self.tfar[at..end].copy_from_slice(&rays.tfar);
        debug_assert!((0..W).all(|k| rays.tfar[k] == f32::NEG_INFINITY
            || traceable(rays.origin(k), rays.direction(k), 0.0, rays.tfar[k])));
        self.geom[at..end].fill(sys::RTC_INVALID_GEOMETRY_ID);
        self.len = end;
        at
    }

    /// The hits of the packet pushed at `at`, after [`Scene::intersect_packets`]; a lane
    /// that was not traced reads as a miss at t = −∞.
    pub fn hits<const W: usize>(&self, at: usize) -> HitsN<W> {
        let end = at + W;
        let arr = |a: &[f32; N]| -> [f32; W] { a[at..end].try_into().expect("W lanes") };
        let words = |a: &[u32; N]| -> [u32; W] { a[at..end].try_into().expect("W lanes") };
        HitsN {
            t: arr(&self.tfar),
            ng: [arr(&self.ng[0]), arr(&self.ng[1]), arr(&self.ng[2])],
            geom: words(&self.geom),
            prim: words(&self.prim),
            u: arr(&self.u),
            v: arr(&self.v),
        }
    }

    /// Embree's SoA view of the stream's rays: a pointer to each of its arrays.
    #[cfg(embree3)]
    fn ray_np(&mut self) -> sys::RTCRayNp {
        sys::RTCRayNp {
            org_x: self.org[0].as_mut_ptr(),
            org_y: self.org[1].as_mut_ptr(),
            org_z: self.org[2].as_mut_ptr(),
            tnear: self.tnear.as_mut_ptr(),
            dir_x: self.dir[0].as_mut_ptr(),
            dir_y: self.dir[1].as_mut_ptr(),
            dir_z: self.dir[2].as_mut_ptr(),
            time: self.time.as_mut_ptr(),
            tfar: self.tfar.as_mut_ptr(),
            mask: self.mask.as_mut_ptr(),
            id: self.id.as_mut_ptr(),
            flags: self.flags.as_mut_ptr(),
        }
    }

    /// Which lanes of the packet pushed at `at` read as blocked after
    /// [`Scene::occluded_packets`] (Embree set their `tfar` to −∞). A lane the push
    /// skipped reads as blocked too: mask the answer with the lanes pushed.
    #[cfg(embree3)]
    #[inline]
    pub fn blocked<const W: usize>(&self, at: usize) -> [bool; W] {
        std::array::from_fn(|k| self.tfar[at + k] == f32::NEG_INFINITY)
    }
}

#[cfg(embree3)]
impl Scene {
    /// Closest hits of every ray of the packet stream (`rtcIntersectNp`).
    pub fn intersect_packets<const N: usize>(
        &self,
        stream: &mut PacketStream<N>,
        coherence: Coherence,
    ) {
        let s = stream;
        let rays = sys::RTCRayHitNp {
            ray: s.ray_np(),
            hit: sys::RTCHitNp {
                Ng_x: s.ng[0].as_mut_ptr(),
                Ng_y: s.ng[1].as_mut_ptr(),
                Ng_z: s.ng[2].as_mut_ptr(),
                u: s.u.as_mut_ptr(),
                v: s.v.as_mut_ptr(),
                primID: s.prim.as_mut_ptr(),
                geomID: s.geom.as_mut_ptr(),
                instID: [s.inst.as_mut_ptr()],
            },
        };
        let mut ctx = query::Ctx::new(coherence);
        // SAFETY: the scene is committed; every pointer in `rays` points to an array of N
        // ≥ `s.len` elements of the stream, 16-byte aligned (the struct is 64-byte aligned
        // and each array's size a multiple of 16 bytes), which stays borrowed and
        // unmoved for the call.
        unsafe { sys::rtcIntersectNp(self.raw, &mut ctx.0, &rays, s.len as u32) };
    }

    /// Occlusion of every ray of the packet stream (`rtcOccludedNp`): Embree sets a
    /// blocked ray's `tfar` to −∞ ([`PacketStream::blocked`]).
    pub fn occluded_packets<const N: usize>(
        &self,
        stream: &mut PacketStream<N>,
        coherence: Coherence,
    ) {
        let s = stream;
        let rays = s.ray_np();
        let mut ctx = query::Ctx::new(coherence);
        // SAFETY: as in `intersect_packets`: every pointer points to an array of N ≥
        // `s.len` elements of the stream, 16-byte aligned, borrowed and unmoved for the
        // call.
        unsafe { sys::rtcOccludedNp(self.raw, &mut ctx.0, &rays, s.len as u32) };
    }
}

/// Sets flush-to-zero and denormals-are-zero in MXCSR, as Embree asks of every thread
/// that traces. Call it from rayon's `start_handler` and on the main thread.
pub fn set_flush_denormals() {
    #[cfg(target_arch = "x86_64")]
    {
        #[allow(deprecated)]
        // SAFETY: reading and writing MXCSR only changes this thread's float rounding of
        // denormals; no memory is touched.
        unsafe {
            use std::arch::x86_64::{_mm_getcsr, _mm_setcsr};
            _mm_setcsr(_mm_getcsr() | 0x8040);
        }
    }
}

/// A rayon pool whose threads all have flush-to-zero/denormals-are-zero set.
/// `threads == 0` means one per core.
pub fn thread_pool(threads: usize) -> Result<rayon::ThreadPool, rayon::ThreadPoolBuildError> {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .start_handler(|_| set_flush_denormals())
        .build()
}
