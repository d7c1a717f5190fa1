//! Zenoh client configuration of an agent (agent/protocol/session.py: client_config, the same settings).
//!
//! The agent's credentials come from its environment (FLUIDSWARM_ZENOH_USER, FLUIDSWARM_ZENOH_PASSWORD, set
//! by the launcher: agent/protocol/access.py), never from its command line, which any local user can read.

use zenoh::Config;

pub const USER_ENV: &str = "FLUIDSWARM_ZENOH_USER";
pub const PASSWORD_ENV: &str = "FLUIDSWARM_ZENOH_PASSWORD";

/// The credentials handed over in the environment, if any: (user, password).
pub fn env_credentials() -> (String, String) {
    (std::env::var(USER_ENV).unwrap_or_default(), std::env::var(PASSWORD_ENV).unwrap_or_default())
}

pub fn client_config(endpoints: &[String], user: &str, password: &str) -> Result<Config, String> {
    let mut conf = Config::default();
    let set =
        |conf: &mut Config, key: &str, value: String| conf.insert_json5(key, &value).map_err(|e| format!("{key}: {e}"));
    set(&mut conf, "mode", "\"client\"".into())?;
    set(&mut conf, "connect/endpoints", serde_json::to_string(endpoints).map_err(|e| e.to_string())?)?;
    // Retry for up to 2 minutes, not forever: 300 processes starting at once overwhelm a router's accept
    // queue unless clients retry, but one still connecting when its launcher died must end.
    set(&mut conf, "connect/timeout_ms", "120000".into())?;
    set(&mut conf, "scouting/multicast/enabled", "false".into())?;
    if !user.is_empty() {
        set(&mut conf, "transport/auth/usrpwd/user", serde_json::Value::from(user).to_string())?;
        set(&mut conf, "transport/auth/usrpwd/password", serde_json::Value::from(password).to_string())?;
    }
    Ok(conf)
}
