//! fluidswarm-router: the compiled Zenoh router (src/router_program.rs), which is the agent's program started
//! under this name (src/main.rs looks at its argv[0]). One program for both: a release build then links all of
//! zenoh with thin LTO once, not twice (each such link generates the machine code of all of zenoh: ~125 s of
//! CPU, 2 min of a fresh clone's 2 cores; issue 52).
//!
//! This program only hands over, and links no zenoh: it replaces itself (exec: the same process id, arguments,
//! environment and open files) by `fluidswarm-agent` from its own folder, with argv[0] `fluidswarm-router`.
//! Its folder is the real one (/proc/self/exe), also when it is started through a symbolic link.

use std::os::unix::process::CommandExt;
use std::process::Command;

fn fail(msg: &str) -> ! {
    eprintln!("fluidswarm router: error: {msg}");
    std::process::exit(2)
}

fn main() {
    let me = std::env::current_exe().unwrap_or_else(|e| fail(&format!("cannot find this program's folder: {e}")));
    let agent = me.with_file_name(format!("fluidswarm-agent{}", std::env::consts::EXE_SUFFIX));
    let err = Command::new(&agent).arg0("fluidswarm-router").args(std::env::args_os().skip(1)).exec();
    fail(&format!("cannot start {} as the router: {err}", agent.display()))
}
