//! A secured Zenoh session (team keys from `slate_node::team_keys`, TLS with mutual
//! authentication, the generated access control) between raw sessions on 127.0.0.1: a
//! member may speak only on its own keys, whatever the message (the kind is the payload's
//! first byte, so a forged report, lifecycle, object list, heartbeat, hello or stream
//! position in another's name is one put on that module's key); a session without a
//! certificate gets no link. The same forgery on an insecure session is delivered.

use std::path::Path;
use std::sync::{Arc, Mutex};
use std::time::Duration;

use slate_node::team_keys::{self, Identity};
use slate_testing::{eventually, free_port, temp_dir};
use slate_zenoh::{Security, ZenohConfig};
use zenoh::Wait;

/// The keys a receiving module declares, and the keys of puts it received.
struct Listener {
    _session: zenoh::Session,
    _subscriber: zenoh::pubsub::Subscriber<()>,
    _tokens: zenoh::pubsub::Subscriber<()>,
    heard: Arc<Mutex<Vec<String>>>,
}

fn team_keys(name: &str) -> slate_testing::TempDir {
    let dir = temp_dir(name);
    team_keys::init(&dir, false).unwrap();
    for id in ["t/r1/nav", "t/r2/loco", "t/r3/gps"] {
        team_keys::issue(&dir, &Identity::parse(id).unwrap(), false).unwrap();
    }
    dir
}

fn security(dir: &Path, identity: &str) -> Option<Security> {
    Some(team_keys::security(dir, &Identity::parse(identity).unwrap()).unwrap())
}

/// A session listening on `endpoint` that records every put on `slate/**` and every
/// liveliness token it hears.
fn listen(endpoint: &str, security: Option<Security>) -> Listener {
    let config = ZenohConfig {
        listen: vec![endpoint.to_owned()],
        security,
        ..ZenohConfig::default()
    };
    let session = zenoh::open(config.to_zenoh().unwrap()).wait().unwrap();
    let heard = Arc::new(Mutex::new(Vec::new()));
    let h = heard.clone();
    let subscriber = session
        .declare_subscriber("slate/**")
        .callback(move |s| h.lock().unwrap().push(s.key_expr().to_string()))
        .wait()
        .unwrap();
    let h = heard.clone();
    let tokens = session
        .liveliness()
        .declare_subscriber("slate/alive/**")
        .callback(move |s| h.lock().unwrap().push(s.key_expr().to_string()))
        .wait()
        .unwrap();
    Listener {
        _session: session,
        _subscriber: subscriber,
        _tokens: tokens,
        heard,
    }
}

/// A session connected to `endpoint`.
fn connect(endpoint: &str, security: Option<Security>) -> zenoh::Result<zenoh::Session> {
    let config = ZenohConfig {
        connect: vec![endpoint.to_owned()],
        security,
        ..ZenohConfig::default()
    };
    zenoh::open(config.to_zenoh().unwrap()).wait()
}

/// From `sender`: a liveliness token and two puts in nav's name (a 14-byte frame on its
/// publication key, as the object list of finding 4, and a 23-byte one on its direct key
/// to loco, as the lifecycle frame). The token is returned: dropping it withdraws it.
fn forge(sender: &zenoh::Session) -> zenoh::liveliness::LivelinessToken {
    let token = sender
        .liveliness()
        .declare_token("slate/alive/t/r1/nav")
        .wait()
        .unwrap();
    for (key, len) in [
        ("slate/pub/team/t/r1/nav", 14),
        ("slate/to/t/r2/loco/from/t/r1/nav", 23),
    ] {
        sender.put(key, vec![7u8; len]).wait().unwrap();
    }
    token
}

/// From `sender`, as `t/r3/gps`: a put and a token in its own name; returns the keys the
/// listener heard once it heard both (a link keeps order, so what `sender` sent before
/// has arrived by then, if it was let through).
fn speak_own(sender: &zenoh::Session, listener: &Listener) -> Vec<String> {
    sender
        .put("slate/pub/team/t/r3/gps", vec![1u8; 4])
        .wait()
        .unwrap();
    let _token = sender
        .liveliness()
        .declare_token("slate/alive/t/r3/gps")
        .wait()
        .unwrap();
    let heard_own = eventually(Duration::from_secs(10), || {
        let heard = listener.heard.lock().unwrap();
        heard.iter().any(|k| k == "slate/pub/team/t/r3/gps")
            && heard.iter().any(|k| k == "slate/alive/t/r3/gps")
    });
    assert!(heard_own, "{:?}", listener.heard.lock().unwrap());
    listener.heard.lock().unwrap().clone()
}

/// The distinct keys heard in nav's name.
fn in_navs_name(heard: &[String]) -> Vec<&String> {
    let mut keys: Vec<&String> = heard.iter().filter(|k| k.ends_with("t/r1/nav")).collect();
    keys.sort();
    keys.dedup();
    keys
}

#[test]
fn frames_forged_in_another_modules_name_are_delivered_on_an_insecure_link() {
    let endpoint = format!("tcp/127.0.0.1:{}", free_port());
    let listener = listen(&endpoint, None);
    let sender = connect(&endpoint, None).unwrap();
    let _forged = forge(&sender);
    let heard = speak_own(&sender, &listener);
    assert_eq!(in_navs_name(&heard).len(), 3, "{heard:?}");
    sender.close().wait().unwrap();
}

#[test]
fn a_secured_member_speaking_in_another_modules_name_is_refused_at_the_link() {
    let dir = team_keys("secure-forge");
    let endpoint = format!("tls/127.0.0.1:{}", free_port());
    let listener = listen(&endpoint, security(&dir, "t/r2/loco"));
    let sender = connect(&endpoint, security(&dir, "t/r3/gps")).unwrap();
    let _forged = forge(&sender);
    let heard = speak_own(&sender, &listener);
    assert_eq!(in_navs_name(&heard), Vec::<&String>::new(), "{heard:?}");
    sender.close().wait().unwrap();
}

#[test]
fn a_session_without_a_team_certificate_gets_no_link_to_a_secured_module() {
    let dir = team_keys("secure-nocert");
    let port = free_port();
    let listener = listen(
        &format!("tls/127.0.0.1:{port}"),
        security(&dir, "t/r2/loco"),
    );
    // Plain TCP to the TLS port, and TLS with a certificate of another authority: a peer
    // session opens, but never links (it retries in the background) and is heard by no one.
    let other = team_keys("secure-other-ca");
    let outsiders = [
        connect(&format!("tcp/127.0.0.1:{port}"), None),
        connect(
            &format!("tls/127.0.0.1:{port}"),
            security(&other, "t/r1/nav"),
        ),
    ];
    // A member that speaks after them shows the listener was listening all along.
    let member = connect(&format!("tls/127.0.0.1:{port}"), security(&dir, "t/r3/gps")).unwrap();
    let _forged: Vec<_> = outsiders.iter().flatten().map(forge).collect();
    let heard = speak_own(&member, &listener);
    assert_eq!(in_navs_name(&heard), Vec::<&String>::new(), "{heard:?}");
    for outsider in outsiders.into_iter().flatten() {
        assert!(outsider.info().peers_zid().wait().next().is_none());
        outsider.close().wait().unwrap();
    }
    member.close().wait().unwrap();
}
