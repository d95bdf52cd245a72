//! Being built: see docs/team-protocol.md, section 4.
