//! Liveliness as a world-model fact: the `Module` class and how a module's address
//! names its object.

use slate_model::Address;

/// The `Module` class and its name live with the other built-in classes in slate-model:
/// every board has them from the start (the ICI writes the objects).
pub use slate_model::{MODULE_CLASS, module_class};

/// The name of a module's object: its address with `/` and `-` turned into `_`, and a
/// leading `_` if it would start with a digit: `team/r1/nav` is `team_r1_nav`.
///
/// ```
/// use slate_ici::module_object_name;
/// use slate_model::Address;
/// assert_eq!(module_object_name(&Address::new("team/r1/nav")?), "team_r1_nav");
/// assert_eq!(module_object_name(&Address::new("7th/r-2/cam")?), "_7th_r_2_cam");
/// # Ok::<(), slate_model::AddressError>(())
/// ```
///
/// Two addresses that differ only by `-` against `_` share a name; give modules
/// addresses that do not.
pub fn module_object_name(address: &Address) -> String {
    let name: String = address
        .as_str()
        .chars()
        .map(|c| if c == '/' || c == '-' { '_' } else { c })
        .collect();
    if name.starts_with(|c: char| c.is_ascii_digit()) {
        format!("_{name}")
    } else {
        name
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use slate_model::Board;

    #[test]
    fn the_module_class_defines_on_a_board() {
        let board = Board::new();
        board.define(module_class()).unwrap();
        board.create(MODULE_CLASS, "team_r1_nav").unwrap();
        assert_eq!(
            board.read("team_r1_nav", "alive").unwrap().value.as_f64(),
            None
        );
    }
}
