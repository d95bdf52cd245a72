//! A team's keys (`slate keys`): a certificate authority, and a private key and
//! certificate per module and per operator, signed by it; and the checks a secured node
//! makes of them before it starts (docs/security.md).
//!
//! One folder holds them, each identity's files named by its identity:
//!
//! ```text
//! DIR/ca.pem  DIR/ca.key                     the team's certificate authority
//! DIR/TEAM/ROBOT/MODULE.pem  .key            a module, identity TEAM/ROBOT/MODULE
//! DIR/TEAM/NAME.pem  NAME.key                an operator, identity TEAM/NAME
//! ```
//!
//! A certificate's common name is its identity, written as the address is (`team/r1/nav`;
//! an address's segments are letters, digits, `_` and `-`, so the `/` between them is
//! unambiguous). Private keys are ECDSA P-256 in PKCS#8 PEM, written with permissions 0600
//! and refused by a node when others may read them.

use std::fs::OpenOptions;
use std::io::Write;
use std::os::unix::fs::{OpenOptionsExt, PermissionsExt};
use std::path::{Path, PathBuf};

use rcgen::{
    BasicConstraints, CertificateParams, DnType, ExtendedKeyUsagePurpose, IsCa, Issuer, KeyPair,
    KeyUsagePurpose,
};
use slate_model::Address;
use slate_zenoh::{Security, TeamIdentities};
use x509_parser::certificate::X509Certificate;
use x509_parser::pem::Pem;

/// The authority's certificate, in the keys folder.
pub const CA_CERTIFICATE: &str = "ca.pem";
/// The authority's private key, in the keys folder.
pub const CA_KEY: &str = "ca.key";

/// Deepest an identity's files lie in the keys folder (`TEAM/ROBOT/MODULE.pem`).
const MAX_DEPTH: usize = 3;

/// Who a key and certificate are for.
#[derive(Clone, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum Identity {
    /// A module, by its address `team/robot/module`.
    Module(Address),
    /// An operator of a team, `team/name`, who runs the CLI: its observers join as
    /// `team/ROBOT/cli-name-PID` on any robot.
    Operator {
        /// The team.
        team: String,
        /// The operator's name, the module segment of the addresses it uses.
        name: String,
    },
}

/// What went wrong with a team's keys. Each says which file and what to do.
#[non_exhaustive]
#[derive(Debug, thiserror::Error)]
pub enum KeysError {
    /// The text is neither a module address nor an operator `team/name`.
    #[error(
        "{text:?} is no identity: expected a module address TEAM/ROBOT/MODULE or an operator TEAM/NAME (letters, digits, _ and -)"
    )]
    Identity {
        /// The text given.
        text: String,
    },
    /// The keys folder has no certificate authority.
    #[error("{}: no team certificate authority there; run `slate keys init {}` first", path.display(), dir.display())]
    NoAuthority {
        /// The authority's certificate that is missing.
        path: PathBuf,
        /// The keys folder.
        dir: PathBuf,
    },
    /// A file would be overwritten.
    #[error("{}: already exists; pass --force to replace it (certificates signed by a replaced authority stop working)", path.display())]
    Exists {
        /// The file.
        path: PathBuf,
    },
    /// A file could not be read.
    #[error("{}: cannot read it ({error}); {what_to_do}", path.display())]
    Read {
        /// The file.
        path: PathBuf,
        /// Why.
        error: std::io::Error,
        /// What to do about it.
        what_to_do: String,
    },
    /// A file or folder could not be written.
    #[error("{}: cannot write it ({error})", path.display())]
    Write {
        /// The file.
        path: PathBuf,
        /// Why.
        error: std::io::Error,
    },
    /// A file is not a certificate or key slate can use.
    #[error("{}: {reason}", path.display())]
    Invalid {
        /// The file.
        path: PathBuf,
        /// What is wrong with it, and what to do.
        reason: String,
    },
    /// Generating or signing a key failed.
    #[error("cannot generate a key or certificate: {0}")]
    Generate(String),
}

impl Identity {
    /// A module address (three segments) or an operator `team/name` (two).
    pub fn parse(text: &str) -> Result<Identity, KeysError> {
        let bad = || KeysError::Identity {
            text: text.to_owned(),
        };
        match text.split('/').collect::<Vec<_>>().as_slice() {
            [_, _, _] => Address::new(text).map(Identity::Module).map_err(|_| bad()),
            [team, name] => {
                Address::new(&format!("{team}/operator/{name}")).map_err(|_| bad())?;
                Ok(Identity::Operator {
                    team: (*team).to_owned(),
                    name: (*name).to_owned(),
                })
            }
            _ => Err(bad()),
        }
    }

    /// The certificate's common name: the identity as text.
    pub fn common_name(&self) -> String {
        match self {
            Identity::Module(address) => address.to_string(),
            Identity::Operator { team, name } => format!("{team}/{name}"),
        }
    }

    /// Its certificate in the keys folder `dir`.
    pub fn certificate(&self, dir: &Path) -> PathBuf {
        dir.join(format!("{}.pem", self.common_name()))
    }

    /// Its private key in the keys folder `dir`.
    pub fn private_key(&self, dir: &Path) -> PathBuf {
        dir.join(format!("{}.key", self.common_name()))
    }

    /// Its team.
    pub fn team(&self) -> &str {
        match self {
            Identity::Module(address) => address.team(),
            Identity::Operator { team, .. } => team,
        }
    }

    /// May a session speak as `address` with this identity? A module only as itself, an
    /// operator as its observers `team/ANY/cli-name-ANY` (what the access control allows).
    pub fn may_speak_as(&self, address: &Address) -> bool {
        match self {
            Identity::Module(own) => own == address,
            Identity::Operator { team, .. } => {
                address.team() == team
                    && address
                        .module()
                        .strip_prefix(&self.observer_prefix())
                        .is_some_and(|rest| !rest.is_empty())
            }
        }
    }

    /// The start of the module segment of an operator's observers, `cli-NAME-` (empty
    /// for a module).
    pub fn observer_prefix(&self) -> String {
        match self {
            Identity::Module(_) => String::new(),
            Identity::Operator { name, .. } => {
                format!("{}{name}-", slate_zenoh::OPERATOR_PREFIX)
            }
        }
    }
}

impl std::fmt::Display for Identity {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.common_name())
    }
}

/// Makes a team's certificate authority in `dir` (created if missing); the files written.
/// Refuses to replace an authority unless `force`.
pub fn init(dir: &Path, force: bool) -> Result<Vec<PathBuf>, KeysError> {
    let (cert, key) = (dir.join(CA_CERTIFICATE), dir.join(CA_KEY));
    refuse_existing(&[&cert, &key], force)?;
    let key_pair = KeyPair::generate().map_err(generate)?;
    let mut params = CertificateParams::new(Vec::<String>::new()).map_err(generate)?;
    params
        .distinguished_name
        .push(DnType::CommonName, "slate team certificate authority");
    params.is_ca = IsCa::Ca(BasicConstraints::Constrained(0));
    params.key_usages = vec![KeyUsagePurpose::KeyCertSign, KeyUsagePurpose::CrlSign];
    let ca = params.self_signed(&key_pair).map_err(generate)?;
    write_private(&key, &key_pair.serialize_pem())?;
    write_public(&cert, &ca.pem())?;
    Ok(vec![cert, key])
}

/// Issues `identity`'s private key and certificate, signed by the authority in `dir`;
/// the files written. Refuses to replace them unless `force`.
pub fn issue(dir: &Path, identity: &Identity, force: bool) -> Result<Vec<PathBuf>, KeysError> {
    let issuer = authority(dir)?;
    let (cert, key) = (identity.certificate(dir), identity.private_key(dir));
    refuse_existing(&[&cert, &key], force)?;
    let key_pair = KeyPair::generate().map_err(generate)?;
    let mut params = CertificateParams::new(Vec::<String>::new()).map_err(generate)?;
    params
        .distinguished_name
        .push(DnType::CommonName, identity.common_name());
    params.use_authority_key_identifier_extension = true;
    params.key_usages = vec![KeyUsagePurpose::DigitalSignature];
    // Each node both listens (a server) and connects (a client).
    params.extended_key_usages = vec![
        ExtendedKeyUsagePurpose::ServerAuth,
        ExtendedKeyUsagePurpose::ClientAuth,
    ];
    let signed = params.signed_by(&key_pair, &issuer).map_err(generate)?;
    write_private(&key, &key_pair.serialize_pem())?;
    write_public(&cert, &signed.pem())?;
    Ok(vec![cert, key])
}

/// A team's keys made for one run (a demo, a benchmark) in a fresh folder of the system's
/// temporary directory, removed when dropped.
pub struct TemporaryKeys {
    dir: PathBuf,
}

impl TemporaryKeys {
    /// An authority and a key and certificate for each of `identities`, in a folder
    /// named after `label`, this process and the moment.
    pub fn make(label: &str, identities: &[Identity]) -> Result<TemporaryKeys, KeysError> {
        let nanos = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(0, |d| d.as_nanos());
        let name = format!("slate-{label}-keys-{}-{nanos}", std::process::id());
        let keys = TemporaryKeys {
            dir: std::env::temp_dir().join(name),
        };
        init(&keys.dir, false)?;
        for identity in identities {
            issue(&keys.dir, identity, false)?;
        }
        Ok(keys)
    }

    /// The keys folder.
    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// What a session of `identity` needs to run secured ([`security`]).
    pub fn security(&self, identity: &Identity) -> Result<Security, KeysError> {
        security(&self.dir, identity)
    }
}

impl Drop for TemporaryKeys {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.dir);
    }
}

/// The authority of `dir`, to sign with.
fn authority(dir: &Path) -> Result<Issuer<'static, KeyPair>, KeysError> {
    let cert_path = dir.join(CA_CERTIFICATE);
    if !cert_path.exists() {
        return Err(KeysError::NoAuthority {
            path: cert_path,
            dir: dir.to_owned(),
        });
    }
    let cert = read(&cert_path, "run `slate keys init` to make one")?;
    let key_path = dir.join(CA_KEY);
    let key = read(&key_path, "issue keys where the authority's key is")?;
    let key = KeyPair::from_pem(&key).map_err(|e| invalid(&key_path, &e.to_string()))?;
    Issuer::from_ca_cert_pem(&cert, key).map_err(|e| invalid(&cert_path, &e.to_string()))
}

/// What a session of `identity` needs to run secured from the keys folder `dir`, each
/// file checked: readable, the certificate for `identity` and signed by the team's
/// authority, the private key its own and readable by its owner only; and the team's
/// identities (every certificate in `dir`) for the access control.
pub fn security(dir: &Path, identity: &Identity) -> Result<Security, KeysError> {
    let ca_path = dir.join(CA_CERTIFICATE);
    if !ca_path.exists() {
        return Err(KeysError::NoAuthority {
            path: ca_path,
            dir: dir.to_owned(),
        });
    }
    let ca = read_pem(&ca_path)?;
    let (cert_path, key_path) = (identity.certificate(dir), identity.private_key(dir));
    let cert = read_pem(&cert_path)?;
    let issued = check_signed(&cert_path, &cert, &ca)?;
    if issued != *identity {
        let reason = format!(
            "this certificate is for {issued}, not {identity}; issue one with `slate keys issue {} {identity}`",
            dir.display()
        );
        return Err(invalid(&cert_path, &reason));
    }
    check_private_key(&key_path, &cert_path, &cert)?;
    Ok(Security {
        ca_certificate: ca_path,
        certificate: cert_path,
        private_key: key_path,
        team: Some(team(dir, &ca)?),
    })
}

/// Every identity with a certificate signed by the authority in `dir`.
fn team(dir: &Path, ca: &Pem) -> Result<TeamIdentities, KeysError> {
    let mut found = Vec::new();
    certificates(dir, 0, &mut found)?;
    let mut team = TeamIdentities::default();
    for path in found {
        match check_signed(&path, &read_pem(&path)?, ca)? {
            Identity::Module(a) => team.modules.push(a),
            Identity::Operator { team: t, name } => team.operators.push((t, name)),
        }
    }
    team.modules.sort();
    team.operators.sort();
    Ok(team)
}

/// The `*.pem` files under `dir` but the authority's, at most [`MAX_DEPTH`] deep.
fn certificates(dir: &Path, depth: usize, found: &mut Vec<PathBuf>) -> Result<(), KeysError> {
    let entries = std::fs::read_dir(dir).map_err(|error| KeysError::Read {
        path: dir.to_owned(),
        error,
        what_to_do: "give the keys folder `slate keys init` made".to_owned(),
    })?;
    for entry in entries.flatten() {
        let path = entry.path();
        if path.is_dir() && depth + 1 < MAX_DEPTH {
            certificates(&path, depth + 1, found)?;
        } else if depth > 0 && path.extension().is_some_and(|e| e == "pem") {
            found.push(path);
        }
    }
    Ok(())
}

/// The identity `cert` (read from `path`) is for, once checked to be signed by `ca`.
fn check_signed(path: &Path, cert: &Pem, ca: &Pem) -> Result<Identity, KeysError> {
    let cert = parse_certificate(path, cert)?;
    let ca = parse_certificate(path, ca)?;
    if cert.verify_signature(Some(ca.public_key())).is_err() {
        let reason = "not signed by this team's certificate authority (ca.pem); issue it again with `slate keys issue`";
        return Err(invalid(path, reason));
    }
    let common_name = cert
        .subject()
        .iter_common_name()
        .next()
        .and_then(|cn| cn.as_str().ok())
        .ok_or_else(|| invalid(path, "the certificate names no identity (common name)"))?;
    Identity::parse(common_name).map_err(|e| invalid(path, &e.to_string()))
}

/// Checks that the private key at `key_path` is readable by its owner only and is the
/// one certified by `cert`.
fn check_private_key(key_path: &Path, cert_path: &Path, cert: &Pem) -> Result<(), KeysError> {
    let text = read(key_path, "issue the module's key with `slate keys issue`")?;
    let mode = std::fs::metadata(key_path).map_or(0, |m| m.permissions().mode());
    if mode & 0o077 != 0 {
        let reason = format!(
            "others may read this private key (mode {:o}); run `chmod 600 {}`",
            mode & 0o777,
            key_path.display()
        );
        return Err(invalid(key_path, &reason));
    }
    let key = KeyPair::from_pem(&text).map_err(|e| invalid(key_path, &e.to_string()))?;
    let cert = parse_certificate(cert_path, cert)?;
    if cert.public_key().subject_public_key.data.as_ref() != key.public_key_raw() {
        let reason = format!(
            "this key is not the one {} certifies; keep each key with its certificate",
            cert_path.display()
        );
        return Err(invalid(key_path, &reason));
    }
    Ok(())
}

fn parse_certificate<'p>(path: &Path, pem: &'p Pem) -> Result<X509Certificate<'p>, KeysError> {
    pem.parse_x509()
        .map_err(|e| invalid(path, &format!("not an X.509 certificate ({e})")))
}

/// The first PEM block of a file.
fn read_pem(path: &Path) -> Result<Pem, KeysError> {
    let text = read(
        path,
        "copy it from the team's keys folder or issue it again",
    )?;
    match x509_parser::pem::parse_x509_pem(text.as_bytes()) {
        Ok((_, pem)) if pem.label == "CERTIFICATE" => Ok(pem),
        _ => Err(invalid(path, "not a PEM certificate")),
    }
}

fn read(path: &Path, what_to_do: &str) -> Result<String, KeysError> {
    std::fs::read_to_string(path).map_err(|error| KeysError::Read {
        path: path.to_owned(),
        error,
        what_to_do: what_to_do.to_owned(),
    })
}

fn refuse_existing(paths: &[&PathBuf], force: bool) -> Result<(), KeysError> {
    match paths.iter().find(|p| p.exists()) {
        Some(path) if !force => Err(KeysError::Exists {
            path: (*path).clone(),
        }),
        _ => Ok(()),
    }
}

/// Writes a private key readable by its owner only (0600, also when it replaces one).
fn write_private(path: &Path, text: &str) -> Result<(), KeysError> {
    write_with_mode(path, text, 0o600)
}

fn write_public(path: &Path, text: &str) -> Result<(), KeysError> {
    write_with_mode(path, text, 0o644)
}

fn write_with_mode(path: &Path, text: &str, mode: u32) -> Result<(), KeysError> {
    let failed = |error| KeysError::Write {
        path: path.to_owned(),
        error,
    };
    if let Some(parent) = path.parent() {
        std::fs::create_dir_all(parent).map_err(failed)?;
    }
    let _ = std::fs::remove_file(path);
    let mut file = OpenOptions::new()
        .write(true)
        .create_new(true)
        .mode(mode)
        .open(path)
        .map_err(failed)?;
    file.write_all(text.as_bytes()).map_err(failed)
}

fn invalid(path: &Path, reason: &str) -> KeysError {
    KeysError::Invalid {
        path: path.to_owned(),
        reason: reason.to_owned(),
    }
}

fn generate(e: rcgen::Error) -> KeysError {
    KeysError::Generate(e.to_string())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A fresh, empty keys folder, removed when the test ends.
    fn dir(name: &str) -> slate_testing::TempDir {
        slate_testing::temp_dir(&format!("keys-{name}"))
    }

    fn module(text: &str) -> Identity {
        Identity::parse(text).unwrap()
    }

    #[test]
    fn identities_are_module_addresses_or_team_and_name() {
        assert_eq!(
            module("t/r1/nav"),
            Identity::Module(Address::new("t/r1/nav").unwrap())
        );
        let alice = module("t/alice");
        assert_eq!(alice.common_name(), "t/alice");
        assert!(alice.may_speak_as(&Address::new("t/r2/cli-alice-42").unwrap()));
        assert!(!alice.may_speak_as(&Address::new("t/r2/cli-alicex-42").unwrap()));
        assert!(!alice.may_speak_as(&Address::new("t/r2/nav").unwrap()));
        assert!(!alice.may_speak_as(&Address::new("u/r2/cli-alice-42").unwrap()));
        for bad in ["nav", "t/r 1/nav", "a/b/c/d", "t/", "../x"] {
            assert!(Identity::parse(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn an_issued_certificate_is_checked_against_its_identity_and_key() {
        let d = dir("check");
        init(&d, false).unwrap();
        let nav = module("t/r1/nav");
        issue(&d, &nav, false).unwrap();
        issue(&d, &module("t/alice"), false).unwrap();
        let security = security(&d, &nav).unwrap();
        let team = security.team.unwrap();
        assert_eq!(team.modules, [Address::new("t/r1/nav").unwrap()]);
        assert_eq!(team.operators, [("t".into(), "alice".into())]);
        // A certificate copied over another's is refused, naming both.
        let cam = module("t/r1/cam");
        std::fs::copy(nav.certificate(&d), cam.certificate(&d)).unwrap();
        let err = super::security(&d, &cam).unwrap_err().to_string();
        assert!(
            err.contains("cam.pem: this certificate is for t/r1/nav, not t/r1/cam"),
            "{err}"
        );
    }

    #[test]
    fn a_private_key_others_may_read_is_refused() {
        let d = dir("mode");
        init(&d, false).unwrap();
        let nav = module("t/r1/nav");
        issue(&d, &nav, false).unwrap();
        let key = nav.private_key(&d);
        let mode = std::fs::metadata(&key).unwrap().permissions().mode();
        assert_eq!(mode & 0o777, 0o600);
        std::fs::set_permissions(&key, std::fs::Permissions::from_mode(0o644)).unwrap();
        let err = security(&d, &nav).unwrap_err().to_string();
        assert!(err.contains("chmod 600"), "{err}");
    }
}
