//! Containing panics of dependencies at a source boundary.
//!
//! The Arrow IPC and Parquet readers validate what they decode (we never turn validation
//! off), but some malformed inputs still make them panic (upstream bugs: they should return
//! an error). A reader call that could reach such a panic runs through [`contain`], which
//! turns the panic into an `Err` carrying its message; the caller reports it as a file error
//! naming the file and the batch / row group, and never touches that reader again.
//!
//! This is a backstop, not the validation: gradtac's own code checks what it reads, and a
//! panic in gradtac's own code is a bug that a fuzz target reports (see `docs/fuzzing.md`).
//!
//! Containment is silent: the first call installs (once per process) a panic hook that says
//! nothing while the panicking thread is inside [`contain`] — the message reaches the user
//! once, in the error — and hands every other panic to the hook that was installed before
//! (Rust's default one prints it as usual). A program that installs a hook of its own
//! after the first `contain` replaces this one, and is then responsible for staying quiet;
//! [`install_quiet_hook`] lets it install this one first and wrap it.

use std::cell::Cell;
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::sync::Once;

thread_local! {
    /// How many [`contain`] calls the current thread is inside.
    static CONTAINING: Cell<u32> = const { Cell::new(0) };
}

/// Install the quiet hook (idempotent): a panic on a thread inside [`contain`] prints
/// nothing; any other goes to the hook installed before this one.
pub fn install_quiet_hook() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        let previous = std::panic::take_hook();
        std::panic::set_hook(Box::new(move |info| {
            if !is_containing() {
                previous(info);
            }
        }));
    });
}

/// Is the current thread inside [`contain`]?
pub fn is_containing() -> bool {
    CONTAINING.try_with(|c| c.get() > 0).unwrap_or(false)
}

/// Decrements the containing depth when dropped (also while unwinding).
struct Depth;

impl Depth {
    fn enter() -> Self {
        CONTAINING.with(|c| c.set(c.get() + 1));
        Depth
    }
}

impl Drop for Depth {
    fn drop(&mut self) {
        let _ = CONTAINING.try_with(|c| c.set(c.get().saturating_sub(1)));
    }
}

/// Run `f`; a panic inside it becomes `Err(message)`.
///
/// The caller must treat whatever `f` borrowed mutably as poisoned after an `Err` (drop it,
/// do not call it again): that is why the closure is taken as unwind-safe.
///
/// Silent: the panic prints nothing (see the module doc).
pub fn contain<T>(f: impl FnOnce() -> T) -> Result<T, String> {
    install_quiet_hook();
    let r = {
        let _depth = Depth::enter();
        catch_unwind(AssertUnwindSafe(f))
    };
    r.map_err(|p| {
        let msg = p
            .downcast_ref::<&str>()
            .map(|s| s.to_string())
            .or_else(|| p.downcast_ref::<String>().cloned())
            .unwrap_or_else(|| "a panic without a message".to_string());
        let mut msg = msg.replace('\n', " ");
        if msg.len() > 300 {
            let mut cut = 300;
            while !msg.is_char_boundary(cut) {
                cut -= 1;
            }
            msg.truncate(cut);
            msg.push('…');
        }
        msg
    })
}

#[cfg(test)]
mod tests {
    use super::{contain, is_containing};

    #[test]
    fn a_panic_becomes_its_message() {
        assert_eq!(contain(|| 7), Ok(7));
        let e = contain(|| -> u8 { panic!("bad {}", 42) }).unwrap_err();
        assert_eq!(e, "bad 42");
        let v: Vec<u8> = Vec::new();
        let e = contain(|| v[3]).unwrap_err();
        assert!(e.contains("index out of bounds"), "{e}");
    }

    #[test]
    fn the_containing_flag_is_set_inside_only_and_nests() {
        assert!(!is_containing());
        let inner = contain(|| {
            assert!(is_containing());
            let e = contain(|| -> u8 { panic!("inner") }).unwrap_err();
            (e, is_containing())
        });
        assert_eq!(inner, Ok(("inner".to_string(), true)));
        assert!(!is_containing());
        let _ = contain(|| -> u8 { panic!("x") });
        assert!(!is_containing(), "reset after a panic too");
    }
}
