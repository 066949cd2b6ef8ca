//! Panics of third-party decoders, contained and turned into errors.
//!
//! A decoder that panics on corrupt input (draco-oxide does, see `gltf_import::draco`)
//! would otherwise take the process down on a bad file. [`contain`] catches the panic
//! on the calling thread; [`is_containing`] lets a program's panic hook stay silent for
//! it, so the user sees the one-line error instead of a backtrace.

use std::cell::Cell;
use std::panic::{self, AssertUnwindSafe};

thread_local! {
    static CONTAINING: Cell<bool> = const { Cell::new(false) };
}

/// Whether the current thread is inside [`contain`].
pub fn is_containing() -> bool {
    CONTAINING.with(Cell::get)
}

/// Makes the process's panic hook pass on only the panics [`contain`] does not contain
/// (once; later calls do nothing), so that a contained decoder panic prints nothing.
pub fn quiet_contained_panics() {
    static ONCE: std::sync::Once = std::sync::Once::new();
    ONCE.call_once(|| {
        let inner = panic::take_hook();
        panic::set_hook(Box::new(move |info| {
            if !is_containing() {
                inner(info);
            }
        }));
    });
}

/// Runs `f`; a panic becomes `Err` with its message. `f` must leave nothing half-updated
/// that the caller reads after an `Err` (decoders here only build fresh values).
pub(crate) fn contain<T>(f: impl FnOnce() -> T) -> Result<T, String> {
    let outer = CONTAINING.with(|c| c.replace(true));
    let result = panic::catch_unwind(AssertUnwindSafe(f));
    CONTAINING.with(|c| c.set(outer));
    result.map_err(|payload| {
        payload
            .downcast_ref::<&str>()
            .map(|s| s.to_string())
            .or_else(|| payload.downcast_ref::<String>().cloned())
            .unwrap_or_else(|| "panic".to_string())
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_panic_becomes_its_message_and_the_flag_is_restored() {
        let hook = panic::take_hook();
        panic::set_hook(Box::new(|_| {}));
        let result: Result<(), String> = contain(|| panic!("min <= max"));
        panic::set_hook(hook);
        assert_eq!(result, Err("min <= max".to_string()));
        assert!(!is_containing());
        assert_eq!(contain(|| 7), Ok(7));
    }
}
