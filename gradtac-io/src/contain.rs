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
//! The default panic hook still prints the panic message to stderr before the error is
//! returned.

use std::panic::{catch_unwind, AssertUnwindSafe};

/// Run `f`; a panic inside it becomes `Err(message)`.
///
/// The caller must treat whatever `f` borrowed mutably as poisoned after an `Err` (drop it,
/// do not call it again): that is why the closure is taken as unwind-safe.
pub fn contain<T>(f: impl FnOnce() -> T) -> Result<T, String> {
    catch_unwind(AssertUnwindSafe(f)).map_err(|p| {
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
    use super::contain;

    #[test]
    fn a_panic_becomes_its_message() {
        assert_eq!(contain(|| 7), Ok(7));
        let e = contain(|| -> u8 { panic!("bad {}", 42) }).unwrap_err();
        assert_eq!(e, "bad 42");
        let v: Vec<u8> = Vec::new();
        let e = contain(|| v[3]).unwrap_err();
        assert!(e.contains("index out of bounds"), "{e}");
    }
}
