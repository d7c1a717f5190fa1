//! State deliveries over router-to-router links, counted by the compiled router itself (issue 37: region shares
//! against id-range shares; docs/multi-host.md).
//!
//! Zenoh's own statistics do the counting (its `stats` feature, our `traffic` feature: the program
//! fluidswarm-router-traffic, which `fluidswarm router --count-traffic` runs): with a key filter on the state
//! keys (`stats/filters`) it counts, per transport, every message put on a key the filter matches, in each
//! direction. This module reads those counters from the router's metrics
//! (the admin space's `@/<zid>/router/metrics`, OpenMetrics text) and keeps the transports whose far end is
//! another router: what crossed between hosts. Parsing is pure (no session); `query` is the thin shell.

/// The key filter the router is configured with: every state, on id keys and on cell keys (docs/protocol.md).
pub const STATE_FILTER: &str = "fluidswarm/*/state/**";

/// The per-key, per-transport message counters of zenoh's metrics (a histogram of payload sizes per key filter
/// and transport: its `_count` is the number of messages), for each direction.
const TX_COUNT: &str = "zenoh_tx_network_message_payload_per_key_per_transport_bytes_count";
const RX_COUNT: &str = "zenoh_rx_network_message_payload_per_key_per_transport_bytes_count";

/// State messages over the links to other routers: `sent` (this router to them) and `received`, with the
/// number of distinct routers at the far ends (`links`).
#[derive(Debug, Default, Clone, Copy, PartialEq, Eq)]
pub struct RouterTraffic {
    pub sent: u64,
    pub received: u64,
    pub links: usize,
}

impl RouterTraffic {
    /// The one-line answer to the `traffic` request (router_program.rs).
    pub fn line(&self) -> String {
        format!("traffic sent={} received={} links={}", self.sent, self.received, self.links)
    }
}

/// The value of label `name` in a metric line's `{...}` label set (values are quoted, `\"` escaped).
fn label<'a>(labels: &'a str, name: &str) -> Option<&'a str> {
    let mut rest = labels;
    while let Some(eq) = rest.find("=\"") {
        let key = rest[..eq].trim_start_matches([',', ' ']);
        let value_start = eq + 2;
        let bytes = rest.as_bytes();
        let mut end = value_start;
        while end < bytes.len() && !(bytes[end] == b'"' && bytes[end - 1] != b'\\') {
            end += 1;
        }
        if key == name {
            return rest.get(value_start..end);
        }
        rest = rest.get(end + 1..)?;
    }
    None
}

/// Sum the put messages on `filter` to and from routers in OpenMetrics `text` (zenoh's metrics).
pub fn from_metrics(text: &str, filter: &str) -> RouterTraffic {
    let mut out = RouterTraffic::default();
    let mut peers: Vec<&str> = Vec::new();
    for line in text.lines() {
        let sent = if line.starts_with(TX_COUNT) {
            true
        } else if line.starts_with(RX_COUNT) {
            false
        } else {
            continue;
        };
        let (Some(open), Some(close)) = (line.find('{'), line.rfind('}')) else { continue };
        let labels = &line[open + 1..close];
        if label(labels, "remote_whatami") != Some("router")
            || label(labels, "key") != Some(filter)
            || label(labels, "message") != Some("put")
        {
            continue;
        }
        let Ok(count) = line[close + 1..].trim().parse::<f64>() else { continue };
        if let Some(zid) = label(labels, "remote_zid") {
            if !peers.contains(&zid) {
                peers.push(zid);
            }
        }
        let count = count as u64;
        if sent {
            out.sent += count;
        } else {
            out.received += count;
        }
    }
    out.links = peers.len();
    out
}

/// This router's counts now, from its own admin space (a local query: no access-control rule is involved).
#[cfg(feature = "traffic")]
pub fn query(session: &zenoh::Session) -> Result<RouterTraffic, String> {
    use zenoh::Wait;
    // per_link=false: one line per transport, not per link; compression=false: plain text, not gzip;
    // disconnected=true: a link to a router that has gone (its host stopped first, or was lost) still counts,
    // by its labels, for the 60 s zenoh keeps them (zenoh-stats GARBAGE_COLLECTION_DELAY); later it is summed
    // into a line without them.
    let selector = format!(
        "@/{}/router/metrics?descriptors=false;compression=false;per_link=false;disconnected=true",
        session.zid()
    );
    let replies = session.get(selector).wait().map_err(|e| format!("metrics: {e}"))?;
    let reply = replies.recv().map_err(|_| "metrics: no reply (the router's admin space is off)".to_string())?;
    let sample = reply.result().map_err(|e| format!("metrics: {e:?}"))?;
    let text = sample.payload().try_to_string().map_err(|e| format!("metrics: {e}"))?;
    Ok(from_metrics(&text, STATE_FILTER))
}

#[cfg(test)]
mod tests {
    use super::*;

    const METRICS: &str = concat!(
        "zenoh_tx_network_message_payload_per_key_per_transport_bytes_count{local_zid=\"a1\",local_whatami=\"router\",",
        "remote_zid=\"b2\",remote_whatami=\"router\",space=\"user\",message=\"put\",priority=\"data\",",
        "shm=\"false\",key=\"fluidswarm/*/state/**\"} 120\n",
        "zenoh_rx_network_message_payload_per_key_per_transport_bytes_count{local_zid=\"a1\",local_whatami=\"router\",",
        "remote_zid=\"b2\",remote_whatami=\"router\",space=\"user\",message=\"put\",priority=\"data\",",
        "shm=\"false\",key=\"fluidswarm/*/state/**\"} 80\n",
        "zenoh_tx_network_message_payload_per_key_per_transport_bytes_count{remote_zid=\"c3\",remote_whatami=\"router\",",
        "message=\"put\",key=\"fluidswarm/*/state/**\"} 5\n",
        // an agent's transport (a client): not between hosts
        "zenoh_tx_network_message_payload_per_key_per_transport_bytes_count{remote_zid=\"d4\",remote_whatami=\"client\",",
        "message=\"put\",key=\"fluidswarm/*/state/**\"} 9000\n",
        // another key filter, another message, the histogram's sum, a comment
        "zenoh_tx_network_message_payload_per_key_per_transport_bytes_count{remote_zid=\"b2\",remote_whatami=\"router\",",
        "message=\"put\",key=\"fluidswarm/*/batch/*\"} 7\n",
        "zenoh_tx_network_message_payload_per_key_per_transport_bytes_count{remote_zid=\"b2\",remote_whatami=\"router\",",
        "message=\"delete\",key=\"fluidswarm/*/state/**\"} 3\n",
        "zenoh_tx_network_message_payload_per_key_per_transport_bytes_sum{remote_zid=\"b2\",remote_whatami=\"router\",",
        "message=\"put\",key=\"fluidswarm/*/state/**\"} 9999\n",
        "# EOF\n",
    );

    #[test]
    fn counts_only_state_puts_to_and_from_routers() {
        let t = from_metrics(METRICS, STATE_FILTER);
        assert_eq!(t, RouterTraffic { sent: 125, received: 80, links: 2 });
        assert_eq!(t.line(), "traffic sent=125 received=80 links=2");
    }

    #[test]
    fn nothing_counted_in_text_without_the_filter() {
        assert_eq!(from_metrics("# EOF\n", STATE_FILTER), RouterTraffic::default());
        assert_eq!(
            from_metrics("zenoh_tx_network_message_payload_per_key_per_transport_bytes_count{ 12\n", STATE_FILTER).sent,
            0
        );
    }

    #[test]
    fn a_label_value_with_an_escaped_quote_is_read_whole() {
        assert_eq!(label(r#"a="x\"y",b="z""#, "b"), Some("z"));
        assert_eq!(label(r#"a="x\"y",b="z""#, "a"), Some(r#"x\"y"#));
        assert_eq!(label(r#"a="x""#, "c"), None);
    }
}
