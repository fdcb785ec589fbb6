//! Python as a front end of the use cases (`feedscope_app::FrontEnd`): a request field is a
//! keyword argument.
use feedscope_app::FrontEnd;

/// Fields are keyword arguments: `compare`, `effort="torque"`.
pub(crate) struct Keywords;

impl FrontEnd for Keywords {
    fn name(&self, field: &str) -> String {
        field.to_string()
    }
    fn spell(&self, field: &str, value: &str) -> String {
        format!("{field}=\"{value}\"")
    }
    fn how_to_add(&self) -> String {
        "History.add(trace, axis, kind)".to_string()
    }
    fn default_machine(&self) -> Option<&str> {
        Some("machine")
    }
}
