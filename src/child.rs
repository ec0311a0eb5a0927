//! Child processes that must not outlive bendscope (the webcam's ffmpeg, a sweep's
//! points), and what `/proc` says about a process.
//!
//! A child started through [`die_with_parent`] gets `PR_SET_PDEATHSIG` (Linux): the
//! kernel kills it when the thread that spawned it ends, also when bendscope itself is
//! killed with SIGKILL and cannot clean up. Spawn such children from a thread that lives
//! as long as they should run (the main thread, or a thread that waits for the child).

use std::process::Command;

/// Makes the child `cmd` starts receive `signal` when the spawning thread ends (Linux
/// `prctl(PR_SET_PDEATHSIG)`); a child whose parent is already gone when it starts
/// does not run. Elsewhere a no-op.
pub fn die_with_parent(cmd: &mut Command, signal: i32) -> &mut Command {
    #[cfg(target_os = "linux")]
    {
        use std::os::unix::process::CommandExt;
        let parent = std::process::id();
        // SAFETY: the closure runs between fork and exec and calls only the
        // async-signal-safe `prctl` and `getppid`; it allocates nothing.
        unsafe {
            cmd.pre_exec(move || {
                if libc::prctl(libc::PR_SET_PDEATHSIG, signal as libc::c_ulong, 0, 0, 0) != 0 {
                    return Err(std::io::Error::last_os_error());
                }
                // The parent died before the prctl: nobody would kill this child.
                if libc::getppid() as u32 != parent {
                    return Err(std::io::Error::from_raw_os_error(libc::ESRCH));
                }
                Ok(())
            });
        }
    }
    #[cfg(not(target_os = "linux"))]
    let _ = signal;
    cmd
}

/// The start time of live process `pid` in clock ticks since boot (field 22 of
/// `/proc/PID/stat`, which tells a process from a later one given the same pid); `None`
/// when there is no such process or it has exited (a zombie).
pub fn process_start_ticks(pid: u32) -> Option<u64> {
    let stat = std::fs::read_to_string(format!("/proc/{pid}/stat")).ok()?;
    // The command name (field 2) is in parentheses and may hold spaces.
    let rest = &stat[stat.rfind(')')? + 1..];
    let fields: Vec<&str> = rest.split_whitespace().collect();
    // rest starts at field 3 (state); field 22 is rest[19].
    if fields.first() == Some(&"Z") || fields.first() == Some(&"X") {
        return None;
    }
    fields.get(19)?.parse().ok()
}

/// The command line of process `pid` (`/proc/PID/cmdline`), empty when unknown.
pub fn process_command_line(pid: u32) -> Vec<String> {
    std::fs::read(format!("/proc/{pid}/cmdline"))
        .map(|bytes| {
            bytes
                .split(|b| *b == 0)
                .filter(|a| !a.is_empty())
                .map(|a| String::from_utf8_lossy(a).into_owned())
                .collect()
        })
        .unwrap_or_default()
}

/// Sends `signal` to process `pid`; the OS error when it cannot.
pub fn send_signal(pid: u32, signal: i32) -> std::io::Result<()> {
    let Ok(pid) = libc::pid_t::try_from(pid) else {
        return Err(std::io::Error::from_raw_os_error(libc::ESRCH));
    };
    // SAFETY: kill has no memory-safety preconditions.
    if unsafe { libc::kill(pid, signal) } == 0 {
        Ok(())
    } else {
        Err(std::io::Error::last_os_error())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::time::{Duration, Instant};

    #[test]
    fn a_live_process_has_a_start_time_and_a_command_line_and_a_killed_one_has_none() {
        let mut child = Command::new("sleep").arg("30").spawn().unwrap();
        let pid = child.id();
        let start = process_start_ticks(pid).expect("sleep runs");
        assert!(process_start_ticks(std::process::id()).unwrap() <= start);
        // Between fork and exec the child has no command line of its own yet.
        let t = Instant::now();
        while process_command_line(pid) != ["sleep", "30"] {
            assert!(
                t.elapsed() < Duration::from_secs(2),
                "{:?}",
                process_command_line(pid)
            );
            std::thread::sleep(Duration::from_millis(5));
        }
        assert_eq!(process_start_ticks(pid), Some(start));
        send_signal(pid, libc::SIGKILL).unwrap();
        // Not yet reaped: a zombie counts as gone.
        let t = Instant::now();
        while process_start_ticks(pid).is_some() {
            assert!(t.elapsed() < Duration::from_secs(2), "still running");
            std::thread::sleep(Duration::from_millis(10));
        }
        child.wait().unwrap();
        assert_eq!(process_start_ticks(pid), None);
        assert!(process_command_line(pid).is_empty());
    }

    #[test]
    fn a_child_started_to_die_with_its_parent_dies_when_the_spawning_thread_ends() {
        let (plain, bound) = std::thread::spawn(|| {
            let plain = Command::new("sleep").arg("30").spawn().unwrap();
            let bound = die_with_parent(Command::new("sleep").arg("31"), libc::SIGKILL)
                .spawn()
                .unwrap();
            (plain, bound)
        })
        .join()
        .unwrap();
        let t = Instant::now();
        while process_start_ticks(bound.id()).is_some() {
            assert!(
                t.elapsed() < Duration::from_secs(2),
                "the bound child lives on"
            );
            std::thread::sleep(Duration::from_millis(10));
        }
        assert!(
            process_start_ticks(plain.id()).is_some(),
            "the plain child lives"
        );
        for mut c in [plain, bound] {
            let _ = c.kill();
            let _ = c.wait();
        }
    }
}
