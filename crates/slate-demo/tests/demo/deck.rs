//! The roles' team exports as `link team` blocks in their `.slate` files, the deck phase
//! (mission plans sent before launch on a fast clean radio), and the acoustic link's
//! report filters (`link-acoustic.slate`).

use slate_demo::{Demo, DemoConfig, Role};
use slate_ici::{ClassSet, LinkKind};
use slate_model::Context;

use super::support::within;

/// What each role let out of its robot when the export policy was Rust (`Role::export`).
fn export_once_in_rust(role: Role) -> ClassSet {
    match role {
        Role::Exec => ClassSet::none()
            .class_in("Robot", &[Context::Self_])
            .class("Target")
            .class("Waypoint"),
        Role::Vision => ClassSet::none().class("Target"),
        Role::Console => ClassSet::none().class("Mission").class("Waypoint"),
        Role::Nav | Role::Prox | Role::Loco => ClassSet::none(),
    }
}

#[test]
fn each_roles_team_export_from_its_files_equals_the_old_rust_one() {
    let demo = within(std::time::Duration::from_secs(20), || {
        Demo::start(DemoConfig::default().seed(3)).unwrap()
    });
    for m in &demo.team.modules {
        let export = m.node.ici().link_policy(LinkKind::Team).map(|p| p.export);
        assert_eq!(
            export.unwrap_or_default(),
            export_once_in_rust(m.role),
            "{}",
            m.address()
        );
    }
}
