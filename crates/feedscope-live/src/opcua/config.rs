//! The OPC UA source file: a TOML file naming the server, the nodes of one axis and how to
//! subscribe to them (docs/opcua.md lists every key).
//!
//! The file is read into a `toml::Table` (serde underneath) and then taken apart key by key, so
//! that every error names the file and the dotted field (`effort.unit`) and every key the
//! reader did not take is an error: a misspelt key must not silently fall back to a default.
use std::path::{Path, PathBuf};

use feedscope::trace::EffortKind;
use toml::{Table, Value};

use crate::source::LiveError;

/// Sampling intervals below this are accepted but warned about: SINUMERIK OPC UA servers
/// sample at 100 ms at best, and many servers revise shorter requests upwards.
pub const SINUMERIK_MIN_SAMPLING_MS: f64 = 100.0;

/// An OPC UA source: server, security, the axis's nodes and the subscription.
#[derive(Debug, Clone, PartialEq)]
pub struct OpcUaConfig {
    /// Where the configuration came from (file path or `inline`), for messages.
    pub origin: String,
    /// Server endpoint URL, `opc.tcp://host:port[/path]` (`server.endpoint`).
    pub endpoint: String,
    /// Message security (`server.security_mode`, `server.security_policy`, certificates).
    pub security: Security,
    /// User name and password (`server.user`, `server.password`); anonymous when absent.
    pub user: Option<(String, String)>,
    /// Axis position node (`position.node`, `position.unit`).
    pub position: PositionNode,
    /// Servo effort node (`effort.node`, `effort.unit`, `effort.torque_per_load_nm`).
    pub effort: EffortNode,
    /// Node of the running program's name (`program.node`), optional.
    pub program_node: Option<String>,
    /// Subscription parameters (`[subscription]`).
    pub subscription: SubscriptionParams,
    /// Connection attempts and reconnection back-off (`[connection]`).
    pub connection: ConnectionParams,
}

/// Message security of the secure channel.
#[derive(Debug, Clone, PartialEq)]
pub enum Security {
    /// No signing, no encryption (`security_mode = "none"`): test benches and isolated cells.
    None,
    /// Signed (`"sign"`) or signed and encrypted (`"sign_and_encrypt"`) messages.
    Secure {
        /// Encrypt as well as sign.
        encrypt: bool,
        /// Security policy URI, e.g. `http://opcfoundation.org/UA/SecurityPolicy#Basic256Sha256`.
        policy_uri: String,
        /// The client's application instance certificate (DER), absolute.
        certificate: PathBuf,
        /// Its private key (PEM), absolute.
        private_key: PathBuf,
        /// Trust a server certificate not yet in the PKI directory's trusted list.
        trust_server_certificate: bool,
    },
}

/// Length unit of the position node.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LengthUnit {
    /// Millimetres (`"mm"`), the usual CNC unit.
    Mm,
    /// Metres (`"m"`).
    M,
    /// Micrometres (`"um"`).
    Um,
}

impl LengthUnit {
    /// Metres per unit.
    pub fn to_m(self) -> f64 {
        match self {
            Self::Mm => 1e-3,
            Self::M => 1.0,
            Self::Um => 1e-6,
        }
    }
}

/// The position node.
#[derive(Debug, Clone, PartialEq)]
pub struct PositionNode {
    /// Node id in OPC UA text form, e.g. `ns=2;s=/Channel/MachineAxis/actToolBasePos[u1,3]`.
    pub node: String,
    /// Its unit.
    pub unit: LengthUnit,
}

/// Unit of the effort node.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum EffortUnit {
    /// Motor current, amperes (`"A"`).
    A,
    /// Motor torque, newton-metres (`"Nm"`).
    Nm,
    /// Drive load in % (`"percent"`); torque = load / 100 × `torque_per_load_nm`.
    Percent {
        /// Motor torque at 100 % load (N·m), as `feedscope import shdr` and `watch` take it.
        torque_per_load_nm: f64,
    },
}

/// The effort node.
#[derive(Debug, Clone, PartialEq)]
pub struct EffortNode {
    /// Node id in OPC UA text form.
    pub node: String,
    /// Its unit.
    pub unit: EffortUnit,
}

impl EffortNode {
    /// What the effort samples are in SI: current (A) or torque (N·m).
    pub fn kind(&self) -> EffortKind {
        match self.unit {
            EffortUnit::A => EffortKind::CurrentA,
            EffortUnit::Nm | EffortUnit::Percent { .. } => EffortKind::TorqueNm,
        }
    }

    /// SI units (A or N·m) per unit of the node's value.
    pub fn to_si(&self) -> f64 {
        match self.unit {
            EffortUnit::A | EffortUnit::Nm => 1.0,
            EffortUnit::Percent { torque_per_load_nm } => torque_per_load_nm / 100.0,
        }
    }
}

/// When the server reports a value (OPC UA `DataChangeTrigger`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Trigger {
    /// On a change of status or value (`"status_value"`, the OPC UA default): a standing axis
    /// sends nothing.
    StatusValue,
    /// Also when only the source timestamp changes (`"status_value_timestamp"`): every sample
    /// the server takes, where the server supports it.
    StatusValueTimestamp,
}

/// Subscription parameters (the server may revise them; the revised sampling interval is what
/// [`crate::Source::sample_interval_s`] reports until samples arrive).
#[derive(Debug, Clone, PartialEq)]
pub struct SubscriptionParams {
    /// Requested sampling interval of each monitored item (ms). Default 100.
    pub sampling_interval_ms: f64,
    /// Publishing interval of the subscription (ms). Default 100.
    pub publishing_interval_ms: f64,
    /// Queue size of each monitored item on the server. Default 10.
    pub queue_size: u32,
    /// Data change trigger. Default [`Trigger::StatusValue`].
    pub trigger: Trigger,
}

/// Connection attempts and reconnection back-off.
#[derive(Debug, Clone, PartialEq)]
pub struct ConnectionParams {
    /// Attempts of the first connection before [`LiveError::Connect`]. Default 3.
    pub attempts: u32,
    /// First wait before a reconnection attempt (ms); doubles after each failure. Default 500.
    pub retry_initial_ms: u64,
    /// Cap of that wait (ms). Default 10000.
    pub retry_max_ms: u64,
    /// Directory of the client's PKI (trusted/rejected server certificates). Default
    /// `feedscope-opcua-pki` in the system's temporary directory.
    pub pki_dir: PathBuf,
}

const POLICIES: [(&str, &str); 4] = [
    ("None", "http://opcfoundation.org/UA/SecurityPolicy#None"),
    (
        "Basic256Sha256",
        "http://opcfoundation.org/UA/SecurityPolicy#Basic256Sha256",
    ),
    (
        "Aes128_Sha256_RsaOaep",
        "http://opcfoundation.org/UA/SecurityPolicy#Aes128_Sha256_RsaOaep",
    ),
    (
        "Aes256_Sha256_RsaPss",
        "http://opcfoundation.org/UA/SecurityPolicy#Aes256_Sha256_RsaPss",
    ),
];

impl OpcUaConfig {
    /// Reads a source file.
    ///
    /// # Errors
    /// [`LiveError::Config`] naming the file and the field: unreadable file, TOML syntax,
    /// missing or unknown key, wrong type, unknown unit, out-of-range number.
    pub fn from_file(path: &Path) -> Result<Self, LiveError> {
        let origin = path.display().to_string();
        let text = std::fs::read_to_string(path).map_err(|e| LiveError::Config {
            file: origin.clone(),
            field: "(file)".into(),
            reason: e.to_string(),
        })?;
        let base = path.parent().unwrap_or(Path::new("."));
        Self::from_toml(&text, &origin, base)
    }

    /// Parses a source file's text; relative certificate paths are taken from `base`.
    ///
    /// # Errors
    /// As [`OpcUaConfig::from_file`], naming `origin` as the file.
    pub fn from_toml(text: &str, origin: &str, base: &Path) -> Result<Self, LiveError> {
        let table: Table = toml::from_str(text).map_err(|e| LiveError::Config {
            file: origin.into(),
            field: "(syntax)".into(),
            reason: e.to_string().trim_end().replace('\n', " "),
        })?;
        let mut root = Fields::new(origin, "", table);

        let mut server = root.table("server")?;
        let endpoint = server.string("endpoint")?;
        if !endpoint.starts_with("opc.tcp://") {
            return Err(server.err("endpoint", "must start with opc.tcp://"));
        }
        let mode = server
            .opt_string("security_mode")?
            .unwrap_or_else(|| "none".into());
        let policy = server.opt_string("security_policy")?;
        let certificate = server.opt_string("certificate")?;
        let private_key = server.opt_string("private_key")?;
        let trust = server
            .opt_bool("trust_server_certificate")?
            .unwrap_or(false);
        let security = match mode.as_str() {
            "none" => {
                if let Some(p) = policy.as_deref().filter(|p| *p != "None") {
                    return Err(server.err(
                        "security_policy",
                        &format!("{p:?} needs security_mode = \"sign\" or \"sign_and_encrypt\""),
                    ));
                }
                Security::None
            }
            "sign" | "sign_and_encrypt" => {
                let policy = policy.unwrap_or_else(|| "Basic256Sha256".into());
                let Some((_, uri)) = POLICIES.iter().find(|(n, _)| *n == policy && *n != "None")
                else {
                    return Err(server.err(
                        "security_policy",
                        &format!(
                            "{policy:?} is not one of Basic256Sha256, Aes128_Sha256_RsaOaep, Aes256_Sha256_RsaPss"
                        ),
                    ));
                };
                let need = |v: Option<String>, key: &str| {
                    v.map(|p| base.join(p)).ok_or_else(|| {
                        server.err(key, &format!("required with security_mode = {mode:?}"))
                    })
                };
                Security::Secure {
                    encrypt: mode == "sign_and_encrypt",
                    policy_uri: (*uri).into(),
                    certificate: need(certificate, "certificate")?,
                    private_key: need(private_key, "private_key")?,
                    trust_server_certificate: trust,
                }
            }
            other => {
                return Err(server.err(
                    "security_mode",
                    &format!("{other:?} is not one of \"none\", \"sign\", \"sign_and_encrypt\""),
                ))
            }
        };
        let user = match (server.opt_string("user")?, server.opt_string("password")?) {
            (Some(u), Some(p)) => Some((u, p)),
            (None, None) => None,
            (Some(_), None) => return Err(server.err("password", "required with user")),
            (None, Some(_)) => return Err(server.err("user", "required with password")),
        };
        server.finish()?;

        let mut pos = root.table("position")?;
        let node = pos.string("node")?;
        let unit = match pos.string("unit")?.as_str() {
            "mm" => LengthUnit::Mm,
            "m" => LengthUnit::M,
            "um" => LengthUnit::Um,
            other => {
                return Err(pos.err(
                    "unit",
                    &format!("{other:?} is not one of \"mm\", \"m\", \"um\""),
                ))
            }
        };
        pos.finish()?;
        let position = PositionNode { node, unit };

        let mut eff = root.table("effort")?;
        let node = eff.string("node")?;
        let unit_text = eff.string("unit")?;
        let per_load = eff.opt_f64("torque_per_load_nm")?;
        let unit = match (unit_text.as_str(), per_load) {
            ("A", None) => EffortUnit::A,
            ("Nm", None) => EffortUnit::Nm,
            ("percent", Some(k)) if k > 0.0 && k.is_finite() => EffortUnit::Percent {
                torque_per_load_nm: k,
            },
            ("percent", Some(k)) => {
                return Err(eff.err("torque_per_load_nm", &format!("{k} is not > 0")))
            }
            ("percent", None) => {
                return Err(eff.err(
                    "torque_per_load_nm",
                    "required with unit = \"percent\" (the motor torque at 100 % load, N·m)",
                ))
            }
            ("A" | "Nm", Some(_)) => {
                return Err(eff.err("torque_per_load_nm", "only with unit = \"percent\""))
            }
            (other, _) => {
                return Err(eff.err(
                    "unit",
                    &format!("{other:?} is not one of \"A\", \"Nm\", \"percent\""),
                ))
            }
        };
        eff.finish()?;
        let effort = EffortNode { node, unit };

        let program_node = match root.opt_table("program")? {
            Some(mut prog) => {
                let node = prog.string("node")?;
                prog.finish()?;
                Some(node)
            }
            None => None,
        };

        let mut sub = root
            .opt_table("subscription")?
            .unwrap_or_else(|| Fields::new(origin, "subscription", Table::new()));
        let sampling_interval_ms = sub.opt_f64("sampling_interval_ms")?.unwrap_or(100.0);
        if !(sampling_interval_ms >= 1.0 && sampling_interval_ms.is_finite()) {
            return Err(sub.err(
                "sampling_interval_ms",
                &format!("{sampling_interval_ms} is not >= 1 ms"),
            ));
        }
        let publishing_interval_ms = sub.opt_f64("publishing_interval_ms")?.unwrap_or(100.0);
        if !(publishing_interval_ms >= 1.0 && publishing_interval_ms.is_finite()) {
            return Err(sub.err(
                "publishing_interval_ms",
                &format!("{publishing_interval_ms} is not >= 1 ms"),
            ));
        }
        let queue_size = sub
            .opt_u64("queue_size", 1, u64::from(u32::MAX))?
            .unwrap_or(10) as u32;
        let trigger = match sub.opt_string("trigger")?.as_deref() {
            None | Some("status_value") => Trigger::StatusValue,
            Some("status_value_timestamp") => Trigger::StatusValueTimestamp,
            Some(other) => {
                return Err(sub.err(
                    "trigger",
                    &format!(
                        "{other:?} is not one of \"status_value\", \"status_value_timestamp\""
                    ),
                ))
            }
        };
        sub.finish()?;

        let mut conn = root
            .opt_table("connection")?
            .unwrap_or_else(|| Fields::new(origin, "connection", Table::new()));
        let attempts = conn.opt_u64("attempts", 1, 1000)?.unwrap_or(3) as u32;
        let retry_initial_ms = conn
            .opt_u64("retry_initial_ms", 1, 3_600_000)?
            .unwrap_or(500);
        let retry_max_ms = conn
            .opt_u64("retry_max_ms", retry_initial_ms, 3_600_000)?
            .unwrap_or(10_000.max(retry_initial_ms));
        let pki_dir = conn
            .opt_string("pki_dir")?
            .map(|p| base.join(p))
            .unwrap_or_else(|| std::env::temp_dir().join("feedscope-opcua-pki"));
        conn.finish()?;
        root.finish()?;

        Ok(Self {
            origin: origin.into(),
            endpoint,
            security,
            user,
            position,
            effort,
            program_node,
            subscription: SubscriptionParams {
                sampling_interval_ms,
                publishing_interval_ms,
                queue_size,
                trigger,
            },
            connection: ConnectionParams {
                attempts,
                retry_initial_ms,
                retry_max_ms,
                pki_dir,
            },
        })
    }

    /// Things that are allowed but probably not meant, in words for the log.
    pub fn warnings(&self) -> Vec<String> {
        let mut w = Vec::new();
        let s = &self.subscription;
        if s.sampling_interval_ms < SINUMERIK_MIN_SAMPLING_MS {
            w.push(format!(
                "{}: subscription.sampling_interval_ms = {} is below 100 ms: SINUMERIK OPC UA \
                 servers sample at 100 ms at best and revise shorter requests; other servers may too",
                self.origin, s.sampling_interval_ms
            ));
        }
        if s.publishing_interval_ms > s.sampling_interval_ms * f64::from(s.queue_size) {
            w.push(format!(
                "{}: subscription.publishing_interval_ms = {} exceeds sampling_interval_ms × \
                 queue_size = {}: the server's queue overflows and samples are lost",
                self.origin,
                s.publishing_interval_ms,
                s.sampling_interval_ms * f64::from(s.queue_size)
            ));
        }
        w
    }
}

/// The keys of one TOML table, taken one by one; what is left at the end is an unknown key.
struct Fields<'a> {
    origin: &'a str,
    path: String,
    table: Table,
}

impl<'a> Fields<'a> {
    fn new(origin: &'a str, path: &str, table: Table) -> Self {
        Self {
            origin,
            path: path.into(),
            table,
        }
    }

    fn field(&self, key: &str) -> String {
        if self.path.is_empty() {
            key.into()
        } else {
            format!("{}.{key}", self.path)
        }
    }

    fn err(&self, key: &str, reason: &str) -> LiveError {
        LiveError::Config {
            file: self.origin.into(),
            field: self.field(key),
            reason: reason.into(),
        }
    }

    fn take(&mut self, key: &str) -> Option<Value> {
        self.table.remove(key)
    }

    fn wrong_type(&self, key: &str, want: &str, got: &Value) -> LiveError {
        self.err(key, &format!("expected {want}, found {}", got.type_str()))
    }

    fn opt_table(&mut self, key: &str) -> Result<Option<Fields<'a>>, LiveError> {
        match self.take(key) {
            None => Ok(None),
            Some(Value::Table(t)) => Ok(Some(Fields::new(self.origin, &self.field(key), t))),
            Some(v) => Err(self.wrong_type(key, "a table", &v)),
        }
    }

    fn table(&mut self, key: &str) -> Result<Fields<'a>, LiveError> {
        self.opt_table(key)?
            .ok_or_else(|| self.err(key, "missing (a required table)"))
    }

    fn opt_string(&mut self, key: &str) -> Result<Option<String>, LiveError> {
        match self.take(key) {
            None => Ok(None),
            Some(Value::String(s)) if s.trim().is_empty() => Err(self.err(key, "is empty")),
            Some(Value::String(s)) => Ok(Some(s)),
            Some(v) => Err(self.wrong_type(key, "a string", &v)),
        }
    }

    fn string(&mut self, key: &str) -> Result<String, LiveError> {
        self.opt_string(key)?
            .ok_or_else(|| self.err(key, "missing (a required key)"))
    }

    fn opt_bool(&mut self, key: &str) -> Result<Option<bool>, LiveError> {
        match self.take(key) {
            None => Ok(None),
            Some(Value::Boolean(b)) => Ok(Some(b)),
            Some(v) => Err(self.wrong_type(key, "true or false", &v)),
        }
    }

    fn opt_f64(&mut self, key: &str) -> Result<Option<f64>, LiveError> {
        match self.take(key) {
            None => Ok(None),
            Some(Value::Float(x)) => Ok(Some(x)),
            Some(Value::Integer(i)) => Ok(Some(i as f64)),
            Some(v) => Err(self.wrong_type(key, "a number", &v)),
        }
    }

    fn opt_u64(&mut self, key: &str, min: u64, max: u64) -> Result<Option<u64>, LiveError> {
        match self.take(key) {
            None => Ok(None),
            Some(Value::Integer(i)) if i >= 0 && (min..=max).contains(&(i as u64)) => {
                Ok(Some(i as u64))
            }
            Some(Value::Integer(i)) => Err(self.err(key, &format!("{i} is not in {min}..={max}"))),
            Some(v) => Err(self.wrong_type(key, "an integer", &v)),
        }
    }

    /// Errors on the first key nobody took.
    fn finish(self) -> Result<(), LiveError> {
        match self.table.keys().next() {
            None => Ok(()),
            Some(k) => Err(self.err(k, "unknown key")),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const MINIMAL: &str = r#"
[server]
endpoint = "opc.tcp://127.0.0.1:4840"
[position]
node = "ns=2;s=X.ActPos"
unit = "mm"
[effort]
node = "ns=2;s=X.ActLoad"
unit = "percent"
torque_per_load_nm = 5.0
"#;

    fn parse(text: &str) -> Result<OpcUaConfig, LiveError> {
        OpcUaConfig::from_toml(text, "t.toml", Path::new("/base"))
    }

    fn field_of(text: &str) -> String {
        match parse(text) {
            Err(LiveError::Config { field, .. }) => field,
            other => panic!("expected a config error, got {other:?}"),
        }
    }

    #[test]
    fn minimal_file_takes_the_documented_defaults() {
        let c = parse(MINIMAL).unwrap();
        assert_eq!(c.security, Security::None);
        assert_eq!(c.effort.kind(), EffortKind::TorqueNm);
        assert!((c.effort.to_si() - 0.05).abs() < 1e-15);
        assert_eq!(c.subscription.queue_size, 10);
        assert_eq!(c.subscription.trigger, Trigger::StatusValue);
        assert_eq!(c.connection.attempts, 3);
        assert!(c.warnings().is_empty());
    }

    #[test]
    fn errors_name_the_field() {
        assert_eq!(
            field_of(&MINIMAL.replace("unit = \"mm\"", "unit = \"inch\"")),
            "position.unit"
        );
        assert_eq!(
            field_of(&MINIMAL.replace("torque_per_load_nm = 5.0", "")),
            "effort.torque_per_load_nm"
        );
        assert_eq!(field_of(&format!("foo = 1\n{MINIMAL}")), "foo");
        assert_eq!(field_of(&format!("{MINIMAL}foo = 1\n")), "effort.foo");
        assert_eq!(
            field_of(&MINIMAL.replace("[position]", "[position]\nnodes = \"x\"")),
            "position.nodes"
        );
        assert_eq!(
            field_of(&MINIMAL.replace("endpoint = \"opc.tcp://127.0.0.1:4840\"", "")),
            "server.endpoint"
        );
        assert_eq!(
            field_of(&format!(
                "{MINIMAL}[subscription]\nsampling_interval_ms = 0.5\n"
            )),
            "subscription.sampling_interval_ms"
        );
        assert_eq!(
            field_of(&MINIMAL.replace(
                "[server]",
                "[server]\nsecurity_mode = \"sign\"\ncertificate = \"c.der\""
            )),
            "server.private_key"
        );
    }

    #[test]
    fn short_sampling_is_allowed_with_a_warning() {
        let c = parse(&format!(
            "{MINIMAL}[subscription]\nsampling_interval_ms = 10\npublishing_interval_ms = 50\n"
        ))
        .unwrap();
        assert_eq!(c.warnings().len(), 1);
    }
}
