//! Every example of the crate runs end to end.

#[test]
fn the_gsr_world_example_runs_and_shows_the_paper_interactions() {
    let out = crate::gsr_world::world_tour().expect("the example runs");
    // Derived absolute positions: 12 m at bearing 0.5 rad from (10, 20) heading 0.
    let (x, y) = (10.0 + 12.0 * 0.5f64.cos(), 20.0 + 12.0 * 0.5f64.sin());
    assert!(out.contains(&format!("absolute [{x:?}, {y:?}]")), "{out}");
    // The close obstacle slowed the vehicle through an on-write function.
    assert!(
        out.contains("gsr speed after the close obstacle: 0.5"),
        "{out}"
    );
    assert!(
        out.contains("obstacle1 clearance (class-level): 1.5"),
        "{out}"
    );
    assert_eq!(out.matches("watch: revision").count(), 2, "{out}");
    assert!(out.contains("object gsr (self, owner gsr/r1/nav)"), "{out}");
}
