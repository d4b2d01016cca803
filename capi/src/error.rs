//! Status codes, the last-error message and the error callback, and the
//! guard every entry point runs its body in.
//!
//! Every `cmlt_*` function returns a [`cmlt_status`]. On failure the message
//! is kept per thread ([`cmlt_last_error`]) and handed to the error
//! callback, if one is set (like Embree's `rtcSetDeviceErrorFunction`).
//! `guard` catches panics, so none ever unwinds into C: a panic is a bug
//! and is reported as [`cmlt_status::CMLT_ERROR_INTERNAL`].

use std::borrow::Cow;
use std::cell::RefCell;
use std::ffi::{c_char, c_void};
use std::fmt::Write as _;
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::sync::{Mutex, TryLockError};

use crate::call;

#[cfg(feature = "test-hooks")]
thread_local! {
    /// Test hook: the next [`bug_hook`] on this thread panics.
    pub(crate) static PANIC_ONCE: std::cell::Cell<bool> = const { std::cell::Cell::new(false) };
}

/// Stands in for a bug in tests: called where a call holds an object's
/// lock (a scene being built, a worker being rendered), it panics once
/// after the test armed [`PANIC_ONCE`]. Does nothing in the library.
#[inline(always)]
pub(crate) fn bug_hook() {
    #[cfg(feature = "test-hooks")]
    if PANIC_ONCE.take() {
        panic!("test hook: a bug while holding a lock");
    }
}

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
    /// A bug in cmlt (a caught panic). An object whose lock the failing
    /// call held (a scene, a renderer, one of a renderer's workers) may be
    /// half-changed and is dead from then on: every later call that needs
    /// it returns `CMLT_ERROR_INTERNAL` again (never `CMLT_ERROR_BUSY`);
    /// release it. Other objects are unaffected.
    CMLT_ERROR_INTERNAL = 7,
    /// The host's allocator (or the system's) refused a block. The object
    /// is left as it was and no handle was made; retrying when memory is
    /// free succeeds.
    CMLT_ERROR_OUT_OF_MEMORY = 8,
}

/// A failed call: its status and message.
#[derive(Debug)]
pub(crate) struct Error {
    pub status: cmlt_status,
    /// A literal where the call may run inside a frame (no allocation).
    pub message: Cow<'static, str>,
}

impl Error {
    pub fn new(status: cmlt_status, message: impl Into<Cow<'static, str>>) -> Self {
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

    pub fn invalid(message: impl Into<Cow<'static, str>>) -> Self {
        Self::new(cmlt_status::CMLT_ERROR_INVALID_ARGUMENT, message)
    }

    pub fn operation(message: impl Into<Cow<'static, str>>) -> Self {
        Self::new(cmlt_status::CMLT_ERROR_INVALID_OPERATION, message)
    }

    pub fn busy(message: impl Into<Cow<'static, str>>) -> Self {
        Self::new(cmlt_status::CMLT_ERROR_BUSY, message)
    }

    pub fn out_of_memory(message: impl Into<Cow<'static, str>>) -> Self {
        Self::new(cmlt_status::CMLT_ERROR_OUT_OF_MEMORY, message)
    }

    /// The object's lock was poisoned by a panic in an earlier call: its
    /// state may be half-changed, so it is dead rather than busy forever.
    pub fn dead() -> Self {
        Self::new(
            cmlt_status::CMLT_ERROR_INTERNAL,
            "an earlier call on this object failed internally (CMLT_ERROR_INTERNAL) \
             and may have left it half-changed: it is unusable, release it",
        )
    }

    /// A failed `try_lock`/`try_read`/`try_write`: busy when another thread
    /// holds the lock, dead when a panic poisoned it.
    pub fn lock<G>(e: TryLockError<G>, busy: &'static str) -> Self {
        match e {
            TryLockError::WouldBlock => Self::busy(busy),
            TryLockError::Poisoned(_) => Self::dead(),
        }
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
    /// Const-initialised and without destructor: touching it allocates
    /// nothing, not even on a thread's first error.
    static LAST_ERROR: RefCell<Message> = const { RefCell::new(Message::EMPTY) };
}

/// Runs an entry point's body: catches panics, records failures for
/// `cmlt_last_error` and the callback, and turns the result into a status.
/// A body that met a refused allocation (see [`crate::alloc`]) fails with
/// `CMLT_ERROR_OUT_OF_MEMORY` whatever it returned, unless it had already
/// published its result (see [`crate::alloc::check_oom`]).
pub(crate) fn guard(name: &str, body: impl FnOnce() -> Result<()>) -> cmlt_status {
    let outer = call::enter();
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
    let refused = call::leave(outer);
    let result = match (result, refused) {
        (Err(e), Some(_)) if e.status != cmlt_status::CMLT_ERROR_INTERNAL => {
            drop(e);
            // A literal: past `call::leave` a refused block would abort.
            Err(Error::out_of_memory(
                "out of memory: the allocator refused a block; nothing was changed",
            ))
        }
        (r, _) => r,
    };
    match result {
        Ok(()) => cmlt_status::CMLT_OK,
        Err(e) => {
            report(name, &e);
            e.status
        }
    }
}

/// Longest message kept for `cmlt_last_error` and the callback (bytes,
/// NUL excluded); longer ones are cut at a character boundary.
const MESSAGE_CAPACITY: usize = 511;

/// A message in fixed storage, so that reporting an error allocates
/// nothing (errors inside a frame must not allocate).
struct Message {
    bytes: [u8; MESSAGE_CAPACITY + 1],
    len: usize,
}

impl Message {
    const EMPTY: Message = Message {
        bytes: [0; MESSAGE_CAPACITY + 1],
        len: 0,
    };
}

impl std::fmt::Write for Message {
    fn write_str(&mut self, s: &str) -> std::fmt::Result {
        for c in s.chars() {
            // Interior NULs would cut the C string short.
            let c = if c == '\0' { ' ' } else { c };
            let n = c.len_utf8();
            if self.len + n > MESSAGE_CAPACITY {
                return Err(std::fmt::Error);
            }
            c.encode_utf8(&mut self.bytes[self.len..]);
            self.len += n;
        }
        Ok(())
    }
}

fn report(name: &str, e: &Error) {
    let callback = CALLBACK
        .lock()
        .map(|c| c.as_ref().map(|c| (c.f, c.user)))
        .unwrap_or(None);
    LAST_ERROR.with(|l| {
        let mut l = l.borrow_mut();
        l.len = 0;
        // A full buffer cuts the message; that is all `write!` can fail for.
        let _ = write!(l, "{name}: {}", e.message);
        let len = l.len;
        l.bytes[len] = 0;
        if let Some((f, user)) = callback {
            // SAFETY: the host registered `f` for exactly this call shape;
            // the message is NUL-terminated and outlives the call.
            unsafe { f(user as *mut c_void, e.status, l.bytes.as_ptr().cast()) };
        }
    });
}

/// The message of the last failed call on this thread ("" if none), valid
/// until the next failing call on this thread. Never NULL.
#[unsafe(no_mangle)]
pub extern "C" fn cmlt_last_error() -> *const c_char {
    LAST_ERROR.with(|l| l.borrow().bytes.as_ptr().cast())
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
        x if x == CMLT_ERROR_OUT_OF_MEMORY as u32 => b"CMLT_ERROR_OUT_OF_MEMORY\0",
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
