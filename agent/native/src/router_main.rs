//! fluidswarm-router: the compiled Zenoh router (src/router_program.rs).

fn main() {
    fluidswarm_agent::router_program::main()
}
