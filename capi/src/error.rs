//! Status codes, the last-error message and the error callback, and the
//! guard every entry point runs its body in.
//!
//! Every `cmlt_*` function returns a [`cmlt_status`]. On failure the message
//! is kept per thread ([`cmlt_last_error`]) and handed to the error
//! callback, if one is set (like Embree's `rtcSetDeviceErrorFunction`).
//! [`guard`] catches panics, so none ever unwinds into C: a panic is a bug
//! and is reported as [`cmlt_status::CMLT_ERROR_INTERNAL`].

use std::cell::RefCell;
use std::ffi::{CString, c_char, c_void};
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::sync::Mutex;

/// Result of every C API call.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[allow(non_camel_case_types)]
pub enum cmlt_status {
    /// Success.
    CMLT_OK = 0,
    /// A required pointer argument was NULL.
    CMLT_ERROR_NULL_POINTER = 1,
    /// An argument is out of range: a size, stride, count, enum value,
    /// a NaN or infinite number, an index.
    CMLT_ERROR_INVALID_ARGUMENT = 2,
    /// The call is not valid in the object's current state (e.g. rendering
    /// before `cmlt_renderer_prepare`, editing a committed scene).
    CMLT_ERROR_INVALID_OPERATION = 3,
    /// The object is in use by another thread (a worker being rendered, a
    /// renderer being prepared while workers render).
    CMLT_ERROR_BUSY = 4,
    /// A file could not be read or parsed.
    CMLT_ERROR_IO = 5,
    /// The feature is not compiled into this build (e.g. Embree).
    CMLT_ERROR_UNSUPPORTED = 6,
    /// A bug in cmlt (a caught panic). The object is left as it was.
    CMLT_ERROR_INTERNAL = 7,
}

/// A failed call: its status and message.
#[derive(Debug)]
pub(crate) struct Error {
    pub status: cmlt_status,
    pub message: String,
}

impl Error {
    pub fn new(status: cmlt_status, message: impl Into<String>) -> Self {
        Error {
            status,
            message: message.into(),
        }
    }

    pub fn null(what: &str) -> Self {
        Self::new(
            cmlt_status::CMLT_ERROR_NULL_POINTER,
            format!("{what} is NULL"),
        )
    }

    pub fn invalid(message: impl Into<String>) -> Self {
        Self::new(cmlt_status::CMLT_ERROR_INVALID_ARGUMENT, message)
    }

    pub fn operation(message: impl Into<String>) -> Self {
        Self::new(cmlt_status::CMLT_ERROR_INVALID_OPERATION, message)
    }

    pub fn busy(message: impl Into<String>) -> Self {
        Self::new(cmlt_status::CMLT_ERROR_BUSY, message)
    }
}

pub(crate) type Result<T> = std::result::Result<T, Error>;

/// Error callback: receives the user pointer given with it, the status and
/// the message (valid during the call only).
#[allow(non_camel_case_types)]
pub type cmlt_error_callback =
    Option<unsafe extern "C" fn(user: *mut c_void, status: cmlt_status, message: *const c_char)>;

struct Callback {
    f: unsafe extern "C" fn(*mut c_void, cmlt_status, *const c_char),
    user: usize,
}

static CALLBACK: Mutex<Option<Callback>> = Mutex::new(None);

thread_local! {
    static LAST_ERROR: RefCell<CString> = RefCell::new(CString::default());
}

/// Runs an entry point's body: catches panics, records failures for
/// `cmlt_last_error` and the callback, and turns the result into a status.
pub(crate) fn guard(name: &str, body: impl FnOnce() -> Result<()>) -> cmlt_status {
    let result = catch_unwind(AssertUnwindSafe(body)).unwrap_or_else(|panic| {
        let what = panic
            .downcast_ref::<&str>()
            .map(|s| s.to_string())
            .or_else(|| panic.downcast_ref::<String>().cloned())
            .unwrap_or_default();
        Err(Error::new(
            cmlt_status::CMLT_ERROR_INTERNAL,
            format!("internal error (please report): {what}"),
        ))
    });
    match result {
        Ok(()) => cmlt_status::CMLT_OK,
        Err(e) => {
            report(name, &e);
            e.status
        }
    }
}

fn report(name: &str, e: &Error) {
    // Interior NULs cannot come from our messages, but never panic here.
    let text =
        CString::new(format!("{name}: {}", e.message).replace('\0', " ")).unwrap_or_default();
    let callback = CALLBACK
        .lock()
        .map(|c| c.as_ref().map(|c| (c.f, c.user)))
        .unwrap_or(None);
    if let Some((f, user)) = callback {
        // SAFETY: the host registered `f` for exactly this call shape; the
        // message outlives the call.
        unsafe { f(user as *mut c_void, e.status, text.as_ptr()) };
    }
    LAST_ERROR.with(|l| *l.borrow_mut() = text);
}

/// The message of the last failed call on this thread ("" if none), valid
/// until the next failing call on this thread. Never NULL.
#[unsafe(no_mangle)]
pub extern "C" fn cmlt_last_error() -> *const c_char {
    LAST_ERROR.with(|l| l.borrow().as_ptr())
}

/// Sets (or, with `callback` NULL, removes) the process-wide error
/// callback, called on the failing thread for every failed call before it
/// returns. The callback must not call back into cmlt.
#[unsafe(no_mangle)]
pub extern "C" fn cmlt_set_error_callback(
    callback: cmlt_error_callback,
    user: *mut c_void,
) -> cmlt_status {
    guard("cmlt_set_error_callback", || {
        let mut slot = CALLBACK
            .lock()
            .map_err(|_| Error::new(cmlt_status::CMLT_ERROR_INTERNAL, "callback lock poisoned"))?;
        *slot = callback.map(|f| Callback {
            f,
            user: user as usize,
        });
        Ok(())
    })
}

/// A readable name of a status value ("CMLT_OK", …; "unknown status" for
/// values that are none). Never NULL. Takes the value as an integer so any
/// number a host passes is safe.
#[unsafe(no_mangle)]
pub extern "C" fn cmlt_status_name(status: u32) -> *const c_char {
    use cmlt_status::*;
    let s: &'static [u8] = match status {
        x if x == CMLT_OK as u32 => b"CMLT_OK\0",
        x if x == CMLT_ERROR_NULL_POINTER as u32 => b"CMLT_ERROR_NULL_POINTER\0",
        x if x == CMLT_ERROR_INVALID_ARGUMENT as u32 => b"CMLT_ERROR_INVALID_ARGUMENT\0",
        x if x == CMLT_ERROR_INVALID_OPERATION as u32 => b"CMLT_ERROR_INVALID_OPERATION\0",
        x if x == CMLT_ERROR_BUSY as u32 => b"CMLT_ERROR_BUSY\0",
        x if x == CMLT_ERROR_IO as u32 => b"CMLT_ERROR_IO\0",
        x if x == CMLT_ERROR_UNSUPPORTED as u32 => b"CMLT_ERROR_UNSUPPORTED\0",
        x if x == CMLT_ERROR_INTERNAL as u32 => b"CMLT_ERROR_INTERNAL\0",
        _ => b"unknown status\0",
    };
    s.as_ptr().cast()
}

/// Reads `*ptr`, or fails with a NULL-pointer error naming `what`.
///
/// # Safety
/// `ptr` is NULL or points to a valid, initialised `T`.
pub(crate) unsafe fn read<'a, T>(ptr: *const T, what: &str) -> Result<&'a T> {
    // SAFETY: forwarded from the caller.
    unsafe { ptr.as_ref() }.ok_or_else(|| Error::null(what))
}

/// `&mut *ptr`, or a NULL-pointer error naming `what`.
///
/// # Safety
/// `ptr` is NULL or points to a valid `T` nobody else accesses during the
/// call.
pub(crate) unsafe fn write<'a, T>(ptr: *mut T, what: &str) -> Result<&'a mut T> {
    // SAFETY: forwarded from the caller.
    unsafe { ptr.as_mut() }.ok_or_else(|| Error::null(what))
}
