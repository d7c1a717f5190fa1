//! The compiled Zenoh router of fluidswarm, with the state relay on its own session (docs/protocol.md,
//! docs/security.md, docs/multi-host.md); swarmhost/router_process.py starts it. Two programs are this module:
//! the agent's (src/main.rs) when started as fluidswarm-router (src/router_main.rs hands over to it so: one
//! program, one thin-LTO link of zenoh), and src/router_traffic_main.rs built with the `traffic` feature.
//!
//! ```text
//! fluidswarm-router RUN     a launcher's embedded router: relays the agents of RUN its launcher adds
//! fluidswarm-router --host  a host's router (`fluidswarm router`, multi-host): relays, for any run, the
//!                           agents each launcher of its host adds over Zenoh (relay.rs HostRelays)
//! fluidswarm-router-traffic RUN | --host   the same, counting the state messages to and from other routers
//!                           (traffic.rs; built with the `traffic` feature: zenoh's statistics)
//! ```
//!
//! Its Zenoh configuration (endpoints, the users file, the access-control rules, TLS) is a JSON file named by
//! FLUIDSWARM_ROUTER_CONFIG, written privately by its starter: never on the command line. The starter talks to
//! it over its stdin and stdout, one line each way (in --host mode the launchers ask over Zenoh instead, the
//! same requests on `fluidswarm/<run>/relay/<zid>`):
//!
//! ```text
//! (first line out)  ready zid=<zid>     the router listens; its Zenoh id
//! add <id> <h>      ok | error <why>    relay agent <id>'s states on cells of side <h> (before it starts)
//! rejected          rejected length=<n> version=<n> value=<n> id=<n> key=<n>
//! traffic           traffic sent=<n> received=<n> links=<n>   state messages to and from other routers
//!                   (fluidswarm-router-traffic only; the other says `error ...`)
//! ```
//!
//! The end of stdin (the starter closed it, or died) closes the router. Exit codes: 0 closed, 2 bad
//! configuration or arguments (one line on stderr).

use std::io::{BufRead, Write};
use std::sync::Arc;

use crate::keys;
use crate::relay::{self, HostRelays, RelayTable, StateRelay};
#[cfg(feature = "traffic")]
use crate::traffic;
use zenoh::Wait;

const CONFIG_ENV: &str = "FLUIDSWARM_ROUTER_CONFIG";

fn fail(msg: &str) -> ! {
    eprintln!("fluidswarm router: error: {msg}");
    std::process::exit(2)
}

/// The program: fluidswarm-router (the agent's program under that name) and fluidswarm-router-traffic are this,
/// built without and with the `traffic` feature.
pub fn main() {
    crate::abort_on_panic();
    // Ctrl-C reaches the whole process group; the launcher still needs its router to tell its agents to stop,
    // and closes the router (our stdin) after them. The end of stdin is also how the launcher's death ends us
    // (the pipe closes with it, however it dies), so no death signal tied to the spawning thread is needed.
    // SAFETY: a plain signal disposition, before any other thread exists.
    unsafe { libc::signal(libc::SIGINT, libc::SIG_IGN) };
    let args: Vec<String> = std::env::args().skip(1).collect();
    let run = match args.as_slice() {
        [host] if host == "--host" => None,
        [run] if keys::valid_run_name(run) => Some(run.clone()),
        _ => fail("usage: fluidswarm-router RUN | --host (a run name: 1-64 letters, digits, '-' or '_'), configuration in $FLUIDSWARM_ROUTER_CONFIG"),
    };
    let path = std::env::var(CONFIG_ENV).unwrap_or_else(|_| fail(&format!("{CONFIG_ENV} is not set")));
    #[cfg_attr(not(feature = "traffic"), allow(unused_mut))]
    let mut config = zenoh::Config::from_file(&path).unwrap_or_else(|e| fail(&format!("{CONFIG_ENV} {path}: {e}")));
    // fluidswarm-router-traffic: zenoh counts the messages on the state keys per transport (its statistics),
    // read back from the admin space, which the `traffic` request queries locally (traffic.rs). The admin space
    // then also answers this router's clients: a measuring router's, not a production one's.
    #[cfg(feature = "traffic")]
    {
        let filters = format!(r#"[{{"key": "{}"}}]"#, traffic::STATE_FILTER);
        for (key, value) in [("stats/filters", filters.as_str()), ("adminspace/enabled", "true")] {
            config.insert_json5(key, value).unwrap_or_else(|e| fail(&format!("counting traffic: {e}")));
        }
    }
    let session = zenoh::open(config).wait().unwrap_or_else(|e| fail(&format!("cannot open the router: {e}")));
    // One relay table for the embedded router's run; a host's router makes one per run on request.
    let table = run.as_deref().map(|run| Arc::new(RelayTable::new(run)));
    let relay = table.as_ref().map(|t| StateRelay::start(&session, t.clone()));
    let relay = relay.transpose().unwrap_or_else(|e| fail(&format!("relay: {e}")));
    let host = if run.is_none() {
        Some(HostRelays::start(&session).unwrap_or_else(|e| fail(&format!("relay: {e}"))))
    } else {
        None
    };
    let mut out = std::io::stdout().lock();
    let say = |out: &mut std::io::StdoutLock, line: &str| writeln!(out, "{line}").and_then(|_| out.flush()).is_ok();
    if !say(&mut out, &format!("ready zid={}", session.zid())) {
        std::process::exit(0);
    }
    for line in std::io::stdin().lock().lines() {
        let Ok(line) = line else { break };
        let reply = match &table {
            // the router's own counters, in either mode (not a run's: what crossed to other routers)
            _ if line.trim() == "traffic" => traffic_line(&session),
            Some(table) => relay::answer(table, &line),
            None => "error a host's router takes its requests over Zenoh (fluidswarm/<run>/relay/<zid>)".to_string(),
        };
        if !say(&mut out, &reply) {
            break;
        }
    }
    // A last resort if closing hangs: SIGALRM's default action ends the process 5 s later regardless.
    // SAFETY: alarm with an integer argument.
    unsafe { libc::alarm(5) };
    drop((relay, host));
    let _ = session.close().wait();
}

#[cfg(feature = "traffic")]
fn traffic_line(session: &zenoh::Session) -> String {
    traffic::query(session).map(|t| t.line()).unwrap_or_else(|e| format!("error {e}"))
}

#[cfg(not(feature = "traffic"))]
fn traffic_line(_session: &zenoh::Session) -> String {
    "error this router does not count: fluidswarm-router-traffic does (make router-traffic)".to_string()
}
