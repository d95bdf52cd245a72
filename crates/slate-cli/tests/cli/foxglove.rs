//! `slate node --foxglove`: a WebSocket client speaking Foxglove's protocol
//! (`foxglove.sdk.v1`, the name the foxglove crate and Foxglove's own bridge use for what
//! was `foxglove.websocket.v1`) connects, reads the advertised channels and their schemas,
//! subscribes, and decodes the packets `slate put` writes on the node.

use std::net::TcpStream;
use std::time::{Duration, Instant};

use serde_json::{Value as Json, json};
use tungstenite::client::IntoClientRequest;
use tungstenite::http::HeaderValue;
use tungstenite::{Message, WebSocket};

use crate::support::{NodeProc, Team, free_port};

/// The subprotocol the client offers: the first version, whose channel advertisements
/// carry their schemas inline.
const SUBPROTOCOL: &str = "foxglove.sdk.v1";

/// A Foxglove client, reading with a time limit.
struct Client {
    ws: WebSocket<TcpStream>,
}

impl Client {
    fn connect(addr: &str) -> Client {
        let stream = TcpStream::connect(addr).expect("connect to the Foxglove server");
        stream
            .set_read_timeout(Some(Duration::from_millis(200)))
            .unwrap();
        let mut request = format!("ws://{addr}/").into_client_request().unwrap();
        request.headers_mut().insert(
            "Sec-WebSocket-Protocol",
            HeaderValue::from_static(SUBPROTOCOL),
        );
        let (ws, response) = tungstenite::client(request, stream).expect("handshake");
        assert_eq!(
            response.headers().get("Sec-WebSocket-Protocol"),
            Some(&HeaderValue::from_static(SUBPROTOCOL))
        );
        Client { ws }
    }

    /// The next message within `limit`, if any.
    fn next(&mut self, limit: Duration) -> Option<Message> {
        let deadline = Instant::now() + limit;
        while Instant::now() < deadline {
            match self.ws.read() {
                Ok(m) => return Some(m),
                Err(tungstenite::Error::Io(e))
                    if matches!(
                        e.kind(),
                        std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut
                    ) => {}
                Err(e) => panic!("the Foxglove connection failed: {e}"),
            }
        }
        None
    }

    /// JSON messages until one has `op`, within 10 s; every channel advertised meanwhile
    /// is added to `channels`.
    fn until_op(&mut self, op: &str, channels: &mut Vec<Json>) -> Json {
        let deadline = Instant::now() + Duration::from_secs(10);
        while Instant::now() < deadline {
            let Some(Message::Text(text)) = self.next(Duration::from_millis(500)) else {
                continue;
            };
            let j: Json = serde_json::from_str(&text).unwrap();
            if j["op"] == "advertise" {
                channels.extend(j["channels"].as_array().cloned().unwrap_or_default());
            }
            if j["op"] == op {
                return j;
            }
        }
        panic!("no {op} message from the Foxglove server");
    }

    fn subscribe(&mut self, subscription: u32, channel: u64) {
        let msg = json!({"op": "subscribe", "subscriptions": [{"id": subscription, "channelId": channel}]});
        self.ws.send(Message::text(msg.to_string())).unwrap();
    }

    /// The payloads of binary message data for `subscription` within `limit`, until
    /// `done` says enough.
    fn data(
        &mut self,
        subscription: u32,
        limit: Duration,
        done: impl Fn(&[u8]) -> bool,
    ) -> Option<Vec<u8>> {
        let deadline = Instant::now() + limit;
        while Instant::now() < deadline {
            let Some(Message::Binary(b)) = self.next(Duration::from_millis(500)) else {
                continue;
            };
            // opcode 1 (message data), subscription id (u32 LE), log time (u64 LE), payload
            if b.len() < 13 || b[0] != 1 {
                continue;
            }
            let id = u32::from_le_bytes(b[1..5].try_into().unwrap());
            if id == subscription && done(&b[13..]) {
                return Some(b[13..].to_vec());
            }
        }
        None
    }
}

fn channel<'c>(channels: &'c [Json], topic: &str) -> &'c Json {
    channels
        .iter()
        .find(|c| c["topic"] == topic)
        .unwrap_or_else(|| panic!("no channel {topic} in {channels:?}"))
}

#[test]
fn a_foxglove_client_gets_a_channel_per_class_with_its_schema_and_the_packets_written() {
    let mut team = Team::new("foxglove");
    let fox = format!("127.0.0.1:{}", free_port());
    let top = format!("foxglove = \"{fox}\"");
    let node = NodeProc::start_config(
        &team.dir,
        "t/r1/nav",
        "object gsr : Vehicle context self;",
        &[],
        &["\"Thing\"", "", &top],
    );
    team.nodes.push(node);

    let mut client = Client::connect(&fox);
    let mut channels = Vec::new();
    let info = client.until_op("serverInfo", &mut channels);
    assert!(
        info["name"].as_str().unwrap().contains("t/r1/nav"),
        "{info}"
    );
    client.until_op("advertise", &mut channels);
    let vehicle = channel(&channels, "/slate/class/Vehicle");
    assert_eq!(vehicle["encoding"], "json");
    assert_eq!(vehicle["schemaName"], "Vehicle");
    assert_eq!(vehicle["schemaEncoding"], "jsonschema");
    let schema: Json = serde_json::from_str(vehicle["schema"].as_str().unwrap()).unwrap();
    // A list of packets, as a recording's class channel has.
    let values = &schema["properties"]["packets"]["items"]["properties"]["values"]["properties"];
    assert_eq!(
        values["speed"]["type"],
        json!(["number", "null"]),
        "{schema}"
    );
    assert_eq!(values["mode"]["type"], json!(["string", "null"]));
    assert_eq!(values["position"]["maxItems"], 2);
    let scene = channel(&channels, "/slate/scene");
    assert_eq!(scene["encoding"], "protobuf");
    assert_eq!(scene["schemaName"], "foxglove.SceneUpdate");

    client.subscribe(1, vehicle["id"].as_u64().unwrap());
    client.subscribe(2, scene["id"].as_u64().unwrap());
    team.ok(&["put", "gsr.mode", "manual"]);
    let payload = client.data(1, Duration::from_secs(10), |p| {
        serde_json::from_slice::<Json>(p).is_ok_and(|j| j["packets"][0]["attr"] == "mode")
    });
    let message: Json = serde_json::from_slice(&payload.expect("the packet of gsr.mode")).unwrap();
    assert_eq!(
        message["packets"].as_array().map(Vec::len),
        Some(1),
        "{message}"
    );
    let packet = &message["packets"][0];
    assert_eq!(packet["object"], "gsr", "{packet}");
    assert_eq!(packet["values"]["mode"], "manual", "{packet}");
    assert!(packet["source"].as_str().unwrap().starts_with("t/r1/cli-"));

    team.ok(&["put", "gsr.position", "[1.5, 2.5]"]);
    let scene_update = client.data(2, Duration::from_secs(10), |p| {
        p.windows(3).any(|w| w == b"gsr")
    });
    assert!(scene_update.is_some(), "no scene update naming gsr");
}

/// A client that subscribes after values were written gets them at once, to it alone:
/// the class's latest packets and the positions on the scene, before any new write.
#[test]
fn a_foxglove_client_gets_the_latest_values_when_it_subscribes() {
    let mut team = Team::new("foxglove-latest");
    let fox = format!("127.0.0.1:{}", free_port());
    let top = format!("foxglove = \"{fox}\"");
    let node = NodeProc::start_config(
        &team.dir,
        "t/r1/nav",
        "object gsr : Vehicle context self { mode = \"survey\"; position = [3.0, 4.0]; }",
        &[],
        &["\"Thing\"", "", &top],
    );
    team.nodes.push(node);

    let mut client = Client::connect(&fox);
    let mut channels = Vec::new();
    client.until_op("advertise", &mut channels);
    let vehicle = channel(&channels, "/slate/class/Vehicle")["id"]
        .as_u64()
        .unwrap();
    let scene = channel(&channels, "/slate/scene")["id"].as_u64().unwrap();
    client.subscribe(1, vehicle);
    let payload = client.data(1, Duration::from_secs(10), |p| {
        serde_json::from_slice::<Json>(p).is_ok_and(|j| j["packets"][0]["attr"] == "mode")
    });
    let message: Json = serde_json::from_slice(&payload.expect("gsr.mode on subscribe")).unwrap();
    let packet = &message["packets"][0];
    assert_eq!(packet["object"], "gsr", "{packet}");
    assert_eq!(packet["values"]["mode"], "survey", "{packet}");
    client.subscribe(2, scene);
    let update = client.data(2, Duration::from_secs(10), |p| {
        p.windows(3).any(|w| w == b"gsr")
    });
    assert!(update.is_some(), "no scene update for gsr on subscribe");
}
