//! The gesture command through its public entry point, `command::decode` (what every agent does with a put on
//! the command key). The first byte picks how the rest is sent: as the whole envelope (forgeries, garbage),
//! or as a body that the harness signs with the run's secret the way the coordinator does, so the fuzzer
//! explores the body checks behind the signature. An accepted command holds only what docs/command.md allows
//! and is followed without a panic or a non-finite control; a different secret accepts nothing.
#![no_main]

use fluidswarm_agent::command::{self, GestureCommand, MAX_CLASSES, MAX_COORD, MAX_ROUTE, MAX_VERTICES, MAX_ZONES, MAX_RINGS};
use fluidswarm_agent::fill::edges_cross;
use fluidswarm_agent::route::{class_of, Follower};
use hmac::{Hmac, Mac};
use libfuzzer_sys::fuzz_target;
use sha2::Sha256;

/// The shared vectors' secret (tests/vectors/commands.json), so their envelopes seed the corpus.
const SECRET: [u8; 32] = [
    0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15, 16, 17, 18, 19, 20, 21, 22, 23, 24, 25, 26, 27, 28, 29,
    30, 31,
];
const OTHER: &[u8] = b"another run's secret";

fn signed(body: &[u8]) -> Vec<u8> {
    let mut mac = Hmac::<Sha256>::new_from_slice(&SECRET).expect("any key length");
    mac.update(body);
    let hex: String = mac.finalize().into_bytes().iter().map(|b| format!("{b:02x}")).collect();
    [b"{\"v\":1,\"body\":".as_slice(), body, b",\"sig\":\"", hex.as_bytes(), b"\"}"].concat()
}

fn in_range(v: f64, lo: f64, hi: f64) -> bool {
    v.is_finite() && lo <= v && v <= hi
}

fn check(cmd: &GestureCommand) {
    assert!(cmd.seq < 1 << 62 && (1..=100_000).contains(&cmd.n_agents), "seq/n_agents");
    assert!(cmd.gesture.chars().count() <= 64);
    assert!((1..=MAX_CLASSES).contains(&cmd.classes.len()));
    assert!(in_range(cmd.beta, 0.0, 1e4) && in_range(cmd.mu, 0.0, 1e4));
    let mut total = 0.0;
    for c in &cmd.classes {
        assert!(c.name.chars().count() <= 64 && in_range(c.share, 0.0, 1e6));
        total += c.share;
        assert!((1..=MAX_ROUTE).contains(&c.route.len()));
        for w in &c.route {
            assert!(in_range(w.x, -MAX_COORD, MAX_COORD) && in_range(w.y, -MAX_COORD, MAX_COORD));
            assert!(in_range(w.r, 0.0, MAX_COORD) && in_range(w.s, 0.0, MAX_COORD) && in_range(w.alpha, 0.0, 1e4));
            assert!(w.beta.map_or(true, |b| in_range(b, 0.0, 1e4)) && w.mu.map_or(true, |m| in_range(m, 0.0, 1e4)));
        }
    }
    assert!(total > 0.0, "shares sum to {total}");
    if let Some(f) = &cmd.fill {
        assert!((1..=MAX_RINGS).contains(&f.rings.len()));
        assert!(f.rings.iter().all(|r| r.len() >= 3) && f.rings.iter().map(Vec::len).sum::<usize>() <= MAX_VERTICES);
        assert!(f.rings.iter().flatten().all(|&(x, y)| in_range(x, -MAX_COORD, MAX_COORD) && in_range(y, -MAX_COORD, MAX_COORD)));
        assert!(!edges_cross(&f.rings), "an accepted shape crosses itself");
        assert!(in_range(f.alpha, 0.0, 1e4) && in_range(f.s, 0.0, MAX_COORD) && f.zones.len() <= MAX_ZONES);
        for z in &f.zones {
            assert!((z.ux * z.ux + z.uy * z.uy - 1.0).abs() <= 1e-6 && z.a > 0.0 && z.b > 0.0);
            assert!(in_range(z.beta, 0.0, 1e4) && in_range(z.mu, 0.0, 1e4));
        }
    }
}

/// What an agent does with an accepted command: its class from its id, then the control at a few positions.
fn follow(cmd: &GestureCommand) {
    let shares: Vec<f64> = cmd.classes.iter().map(|c| c.share).collect();
    for id in [0, cmd.n_agents / 2, cmd.n_agents - 1, cmd.n_agents, cmd.n_agents + 17] {
        let k = class_of(id, cmd.n_agents, &shares);
        assert!(k < cmd.classes.len(), "class {k} of {}", cmd.classes.len());
        let mut f = Follower::for_command(cmd, k);
        for (x, y) in [(0.0, 0.0), (3.5, -2.25), (1e6, 1e6), (-4e5, 7.0)] {
            let c = f.control(x, y);
            let all = [c.wx, c.wy, c.r, c.s, c.alpha, c.beta, c.mu, c.push_x, c.push_y];
            assert!(all.iter().all(|v| v.is_finite()), "control {c:?} at ({x}, {y})");
        }
    }
}

fuzz_target!(|data: &[u8]| {
    let Some((&mode, rest)) = data.split_first() else { return };
    let envelope = if mode & 1 == 0 { rest.to_vec() } else { signed(rest) };
    let result = command::decode(&envelope, &SECRET);
    match &result {
        Ok(cmd) => {
            check(cmd);
            follow(cmd);
            assert!(command::decode(&envelope, &SECRET).as_ref() == Ok(cmd), "decode is not deterministic");
        }
        Err(reason) => assert!([command::MALFORMED, command::REJECT_VERSION, command::SIGNATURE].contains(reason)),
    }
    assert!(command::decode(&envelope, OTHER).is_err(), "accepted under another secret");
});
