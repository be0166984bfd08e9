//! Bounding glibc's malloc arenas for `jink serve` (issue 12: resident memory bounded).
//!
//! glibc gives threads their own malloc arenas, up to 8 per core, and an arena keeps most
//! of what its threads freed instead of returning it to the system. Under the overload
//! benchmark 16 arenas held 260 MB of which 59 MB were in use (`malloc_stats`): the plan
//! and map threads free several MB per job, each into whichever arena it had. Fewer
//! arenas share their free memory between threads instead.
//!
//! The limit is glibc's `glibc.malloc.arena_max` tunable, which glibc reads only at
//! process start, and the workspace forbids the `unsafe` a `mallopt` call needs: so
//! `serve` re-executes itself once, at start, with the tunable added to `GLIBC_TUNABLES`.
//! The process keeps its id, arguments, environment and open files. Nothing is done when
//! the limit is 0, when the environment already sets an arena limit (`GLIBC_TUNABLES`
//! naming `arena_max`, or `MALLOC_ARENA_MAX`), or off glibc; a failed re-execution is
//! reported and the service starts with glibc's default.

/// The tunable bounding the number of arenas.
pub const ARENA_MAX_TUNABLE: &str = "glibc.malloc.arena_max";

/// The value of `GLIBC_TUNABLES` that adds `arena_max = n` to `current`, or `None` when
/// nothing needs doing (`n` is 0, or the environment already bounds the arenas).
pub fn tunables_with_arena_max(
    n: usize,
    current: Option<&str>,
    malloc_arena_max_set: bool,
) -> Option<String> {
    if n == 0 || malloc_arena_max_set {
        return None;
    }
    match current {
        Some(t) if t.contains(ARENA_MAX_TUNABLE) => None,
        Some(t) if !t.is_empty() => Some(format!("{t}:{ARENA_MAX_TUNABLE}={n}")),
        _ => Some(format!("{ARENA_MAX_TUNABLE}={n}")),
    }
}

/// Re-executes this process with at most `n` malloc arenas (see the module docs); returns
/// only when nothing was to be done or the re-execution failed.
pub fn bound(n: usize) {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    {
        use std::os::unix::process::CommandExt;
        let current = std::env::var("GLIBC_TUNABLES").ok();
        let Some(tunables) = tunables_with_arena_max(
            n,
            current.as_deref(),
            std::env::var_os("MALLOC_ARENA_MAX").is_some(),
        ) else {
            return;
        };
        let exe = match std::env::current_exe() {
            Ok(e) => e,
            Err(e) => {
                eprintln!("jink: cannot bound malloc arenas ({e}); using glibc's default");
                return;
            }
        };
        let mut args = std::env::args_os();
        let mut cmd = std::process::Command::new(exe);
        if let Some(arg0) = args.next() {
            cmd.arg0(arg0);
        }
        let err = cmd.args(args).env("GLIBC_TUNABLES", tunables).exec();
        eprintln!("jink: cannot bound malloc arenas ({err}); using glibc's default");
    }
    #[cfg(not(all(target_os = "linux", target_env = "gnu")))]
    let _ = n;
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_arena_limit_is_added_once_and_never_overrides_the_operators() {
        assert_eq!(
            tunables_with_arena_max(2, None, false).as_deref(),
            Some("glibc.malloc.arena_max=2")
        );
        assert_eq!(
            tunables_with_arena_max(2, Some("glibc.malloc.tcache_count=0"), false).as_deref(),
            Some("glibc.malloc.tcache_count=0:glibc.malloc.arena_max=2")
        );
        // Already bounded: by the re-executed process itself, or by the operator.
        assert_eq!(
            tunables_with_arena_max(2, Some("glibc.malloc.arena_max=2"), false),
            None
        );
        assert_eq!(
            tunables_with_arena_max(2, Some("glibc.malloc.arena_max=8"), false),
            None
        );
        assert_eq!(tunables_with_arena_max(2, None, true), None);
        // 0: glibc's default.
        assert_eq!(tunables_with_arena_max(0, None, false), None);
    }
}
