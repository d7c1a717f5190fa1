//! fluidswarm-router-traffic: the compiled Zenoh router built with zenoh's statistics, counting the state messages
//! to and from other routers (src/router_program.rs, src/traffic.rs; the `traffic` feature).

fn main() {
    fluidswarm_agent::router_program::main()
}
