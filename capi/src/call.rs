//! The `cmlt_*` call in progress on this thread: whether there is one, and
//! the first block the allocator refused during it.
//!
//! [`guard`](crate::error::guard) opens a call around every entry point's
//! body and closes it; the allocator ([`crate::alloc`]) notes the blocks it
//! refuses here, and entry points ask before they publish anything
//! ([`check_oom`](crate::alloc::check_oom)). Both depend on this module and
//! it on neither, so the allocator can report errors without the error
//! module knowing the allocator.

use std::cell::Cell;

thread_local! {
    /// Whether this thread is inside a `cmlt_*` call ([`enter`]).
    /// Const-initialised and without destructor, like the next one: the
    /// allocator reads them.
    static IN_CALL: Cell<bool> = const { Cell::new(false) };
    /// Size of the first block the host refused during the current call.
    static REFUSED: Cell<Option<usize>> = const { Cell::new(None) };
}

/// Marks this thread as inside a `cmlt_*` call with no refusal yet;
/// returns what [`leave`] restores.
pub(crate) fn enter() -> (bool, Option<usize>) {
    (IN_CALL.replace(true), REFUSED.take())
}

/// Ends the call [`enter`] began: the size of the first block refused
/// during it, if any.
pub(crate) fn leave(outer: (bool, Option<usize>)) -> Option<usize> {
    IN_CALL.set(outer.0);
    REFUSED.replace(outer.1)
}

/// Whether this thread is inside a `cmlt_*` call.
pub(crate) fn in_call() -> bool {
    IN_CALL.get()
}

/// Notes that a block of `size` bytes was refused; the first refusal of
/// the call is the one kept.
pub(crate) fn note_refused(size: usize) {
    if REFUSED.get().is_none() {
        REFUSED.set(Some(size));
    }
}

/// The size of the first block refused so far in this call, if any.
pub(crate) fn refused() -> Option<usize> {
    REFUSED.get()
}
