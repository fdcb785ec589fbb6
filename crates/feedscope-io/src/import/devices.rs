//! The MTConnect device model (`Devices.xml`): which data items exist, what they measure, in
//! which units, and which axis component each belongs to.
//!
//! An SHDR key is a data item's `name`, or its `id` when no item has that name (the agent's
//! rule). Axes are the `Linear` and `Rotary` components; an item belongs to the nearest one
//! above it. Element names are matched without their namespace, so any MTConnect version reads.
use std::path::Path;

use super::{read_text, ImportError};

/// MTConnect data item category.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Category {
    /// A sampled value (position, load, temperature…).
    Sample,
    /// A discrete state or text.
    Event,
    /// A health condition (`level|nativeCode|nativeSeverity|qualifier|text`).
    Condition,
}

/// How many pipe-separated fields follow a data item's key on an SHDR line.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Shape {
    /// One value.
    Single,
    /// `level|nativeCode|nativeSeverity|qualifier|text` (5 fields).
    Condition,
    /// `nativeCode|text` (2 fields).
    Message,
    /// `code|nativeCode|severity|state|text` (5 fields, deprecated ALARM events).
    Alarm,
    /// `sampleCount|sampleRate|values` (3 fields).
    TimeSeries,
    /// `assetType|assetId` (2 fields, ASSET_CHANGED / ASSET_REMOVED).
    AssetEvent,
}

impl Shape {
    /// Fields after the key.
    pub fn fields(self) -> usize {
        match self {
            Self::Single => 1,
            Self::Message | Self::AssetEvent => 2,
            Self::TimeSeries => 3,
            Self::Condition | Self::Alarm => 5,
        }
    }

    /// Name used in messages.
    pub fn name(self) -> &'static str {
        match self {
            Self::Single => "single value",
            Self::Condition => "CONDITION",
            Self::Message => "MESSAGE",
            Self::Alarm => "ALARM",
            Self::TimeSeries => "TIME_SERIES",
            Self::AssetEvent => "asset event",
        }
    }

    /// True when the last field is free text (which may hold pipes in old SHDR).
    pub fn ends_in_text(self) -> bool {
        matches!(self, Self::Condition | Self::Message | Self::Alarm)
    }
}

/// One `DataItem` element.
#[derive(Debug, Clone, PartialEq)]
pub struct DataItem {
    /// `id` attribute (unique in the model).
    pub id: String,
    /// `name` attribute, the usual SHDR key.
    pub name: Option<String>,
    /// `category`.
    pub category: Category,
    /// `type`, e.g. `POSITION`, `LOAD`.
    pub type_name: String,
    /// `subType`, e.g. `ACTUAL`.
    pub sub_type: Option<String>,
    /// `units`, e.g. `MILLIMETER`, `PERCENT`.
    pub units: Option<String>,
    /// `representation`, e.g. `TIME_SERIES`, `DATA_SET`.
    pub representation: Option<String>,
    /// Coordinate system type (`MACHINE`, `WORK`/`OBJECT`…), from `coordinateSystem` or the
    /// `type` of the `CoordinateSystem` named by `coordinateSystemIdRef`.
    pub coordinate_system: Option<String>,
    /// Element name of the component it belongs to, e.g. `Linear`, `Path`, `Device`.
    pub component: String,
    /// Index into [`Device::axes`] when the item belongs to an axis.
    pub axis: Option<usize>,
}

impl DataItem {
    /// The SHDR key: `name`, else `id`.
    pub fn key(&self) -> &str {
        self.name.as_deref().unwrap_or(&self.id)
    }

    /// The field layout of its SHDR observations.
    pub fn shape(&self) -> Shape {
        let rep = self.representation.as_deref().unwrap_or("");
        match self.category {
            Category::Condition => Shape::Condition,
            Category::Sample
                if rep == "TIME_SERIES" || self.type_name.ends_with("_TIME_SERIES") =>
            {
                Shape::TimeSeries
            }
            Category::Event if self.type_name == "MESSAGE" => Shape::Message,
            Category::Event if self.type_name == "ALARM" => Shape::Alarm,
            Category::Event
                if self.type_name == "ASSET_CHANGED" || self.type_name == "ASSET_REMOVED" =>
            {
                Shape::AssetEvent
            }
            _ => Shape::Single,
        }
    }

    /// `type` with `:subType` when there is one, e.g. `POSITION:ACTUAL`.
    pub fn type_label(&self) -> String {
        match &self.sub_type {
            Some(s) => format!("{}:{s}", self.type_name),
            None => self.type_name.clone(),
        }
    }
}

/// A `Linear` or `Rotary` component.
#[derive(Debug, Clone, PartialEq)]
pub struct AxisComponent {
    /// `id` attribute.
    pub id: String,
    /// `name` attribute.
    pub name: Option<String>,
    /// `nativeName` attribute.
    pub native_name: Option<String>,
    /// `Linear` or `Rotary`.
    pub kind: String,
    /// Indices into [`Device::items`] of the items that belong to it.
    pub items: Vec<usize>,
}

impl AxisComponent {
    /// How the axis is shown: its name, else its id.
    pub fn label(&self) -> &str {
        self.name.as_deref().unwrap_or(&self.id)
    }
}

/// One `Device` element.
#[derive(Debug, Clone, PartialEq)]
pub struct Device {
    /// `id`.
    pub id: String,
    /// `name`.
    pub name: Option<String>,
    /// `uuid`.
    pub uuid: Option<String>,
    /// Every data item of the device, in document order.
    pub items: Vec<DataItem>,
    /// Its axes, in document order.
    pub axes: Vec<AxisComponent>,
}

impl Device {
    /// How the device is shown: its name, else its id.
    pub fn label(&self) -> &str {
        self.name.as_deref().unwrap_or(&self.id)
    }

    /// The item an SHDR key refers to: by `name` first, then by `id`.
    pub fn find_item(&self, key: &str) -> Option<usize> {
        self.items
            .iter()
            .position(|d| d.name.as_deref() == Some(key))
            .or_else(|| self.items.iter().position(|d| d.id == key))
    }

    /// The axis called `wanted`: its `name`, `id` or `nativeName` (exact, then ignoring case).
    ///
    /// # Errors
    /// [`ImportError::UnknownAxis`] listing the axes, or [`ImportError::Item`] when the name is
    /// ambiguous.
    pub fn find_axis(&self, wanted: &str, source_name: &str) -> Result<usize, ImportError> {
        let matches = |eq: &dyn Fn(&str) -> bool| -> Vec<usize> {
            (0..self.axes.len())
                .filter(|&i| {
                    let a = &self.axes[i];
                    a.name.as_deref().is_some_and(eq)
                        || eq(&a.id)
                        || a.native_name.as_deref().is_some_and(eq)
                })
                .collect()
        };
        let mut found = matches(&|s| s == wanted);
        if found.is_empty() {
            found = matches(&|s| s.eq_ignore_ascii_case(wanted));
        }
        match found.as_slice() {
            [i] => Ok(*i),
            [] => Err(ImportError::UnknownAxis {
                source_name: source_name.to_string(),
                wanted: wanted.to_string(),
                found: self.axes_list(),
            }),
            many => Err(ImportError::Item {
                source_name: source_name.to_string(),
                axis: wanted.to_string(),
                reason: format!(
                    "the name matches {} axes (ids {}); give the axis id instead",
                    many.len(),
                    many.iter()
                        .map(|&i| self.axes[i].id.as_str())
                        .collect::<Vec<_>>()
                        .join(", ")
                ),
            }),
        }
    }

    /// `Z1 (Linear, id Lz1), …` for messages.
    pub fn axes_list(&self) -> String {
        if self.axes.is_empty() {
            return format!("none in device {}", self.label());
        }
        self.axes
            .iter()
            .map(|a| format!("{} ({}, id {})", a.label(), a.kind, a.id))
            .collect::<Vec<_>>()
            .join(", ")
    }
}

/// A parsed `Devices.xml`.
#[derive(Debug, Clone, PartialEq)]
pub struct DeviceModel {
    /// The file, for messages.
    pub source_name: String,
    /// The devices in document order.
    pub devices: Vec<Device>,
}

impl DeviceModel {
    /// Read and parse a device model file.
    ///
    /// # Errors
    /// As [`DeviceModel::parse`], and [`ImportError::Io`].
    pub fn read(path: &Path) -> Result<Self, ImportError> {
        let text = read_text(path)?;
        Self::parse(&text, &path.display().to_string())
    }

    /// Parse a device model held in memory.
    ///
    /// # Errors
    /// [`ImportError::BadDevices`] when the text is not XML, holds no `Device`, or a
    /// `DataItem` lacks `id`, `category` or `type`.
    pub fn parse(xml: &str, source_name: &str) -> Result<Self, ImportError> {
        let bad = |reason: String| ImportError::BadDevices {
            source_name: source_name.to_string(),
            reason,
        };
        let doc = roxmltree::Document::parse_with_options(
            xml,
            roxmltree::ParsingOptions {
                allow_dtd: true,
                ..Default::default()
            },
        )
        .map_err(|e| bad(e.to_string()))?;
        let mut devices = Vec::new();
        for dev in doc
            .descendants()
            .filter(|n| n.is_element() && n.tag_name().name() == "Device")
        {
            devices.push(parse_device(dev).map_err(&bad)?);
        }
        if devices.is_empty() {
            return Err(bad(format!(
                "no <Device> element (root element <{}>)",
                doc.root_element().tag_name().name()
            )));
        }
        Ok(Self {
            source_name: source_name.to_string(),
            devices,
        })
    }

    /// `OKUMA (id OKUMA.123456), …` for messages.
    pub fn devices_list(&self) -> String {
        self.devices
            .iter()
            .map(|d| format!("{} (id {})", d.label(), d.id))
            .collect::<Vec<_>>()
            .join(", ")
    }

    /// The device called `wanted` (name, id or uuid).
    pub fn find_device(&self, wanted: &str) -> Option<usize> {
        self.devices.iter().position(|d| {
            d.name.as_deref() == Some(wanted) || d.id == wanted || d.uuid.as_deref() == Some(wanted)
        })
    }
}

fn is_axis(tag: &str) -> bool {
    tag == "Linear" || tag == "Rotary"
}

fn parse_device(dev: roxmltree::Node<'_, '_>) -> Result<Device, String> {
    let attr = |n: roxmltree::Node<'_, '_>, a: &str| n.attribute(a).map(str::to_string);
    let id = attr(dev, "id").ok_or("a <Device> has no id")?;
    // Coordinate systems by id, for `coordinateSystemIdRef`.
    let coord: std::collections::HashMap<&str, &str> = dev
        .descendants()
        .filter(|n| n.is_element() && n.tag_name().name() == "CoordinateSystem")
        .filter_map(|n| Some((n.attribute("id")?, n.attribute("type")?)))
        .collect();
    let mut axes: Vec<AxisComponent> = Vec::new();
    let mut axis_nodes = Vec::new();
    for n in dev
        .descendants()
        .filter(|n| n.is_element() && is_axis(n.tag_name().name()))
    {
        axes.push(AxisComponent {
            id: attr(n, "id").ok_or_else(|| format!("a <{}> has no id", n.tag_name().name()))?,
            name: attr(n, "name"),
            native_name: attr(n, "nativeName"),
            kind: n.tag_name().name().to_string(),
            items: Vec::new(),
        });
        axis_nodes.push(n.id());
    }
    let mut items = Vec::new();
    for n in dev
        .descendants()
        .filter(|n| n.is_element() && n.tag_name().name() == "DataItem")
    {
        let item_id = attr(n, "id").ok_or("a <DataItem> has no id")?;
        let category = match n.attribute("category") {
            Some("SAMPLE") => Category::Sample,
            Some("EVENT") => Category::Event,
            Some("CONDITION") => Category::Condition,
            Some(other) => {
                return Err(format!(
                    "DataItem {item_id}: unknown category `{other}` (SAMPLE, EVENT, CONDITION)"
                ))
            }
            None => return Err(format!("DataItem {item_id} has no category")),
        };
        let type_name = attr(n, "type").ok_or_else(|| format!("DataItem {item_id} has no type"))?;
        // The owning component: the first ancestor that is not a `DataItems` list.
        let owner = n
            .ancestors()
            .skip(1)
            .find(|a| a.is_element() && a.tag_name().name() != "DataItems");
        let component = owner.map_or("Device", |o| o.tag_name().name()).to_string();
        let axis = n
            .ancestors()
            .take_while(|a| a.id() != dev.id())
            .find(|a| a.is_element() && is_axis(a.tag_name().name()))
            .and_then(|a| axis_nodes.iter().position(|&id| id == a.id()));
        let coordinate_system = attr(n, "coordinateSystem").or_else(|| {
            n.attribute("coordinateSystemIdRef")
                .and_then(|r| coord.get(r).map(|t| t.to_string()))
        });
        if let Some(a) = axis {
            axes[a].items.push(items.len());
        }
        items.push(DataItem {
            id: item_id,
            name: attr(n, "name"),
            category,
            type_name,
            sub_type: attr(n, "subType"),
            units: attr(n, "units"),
            representation: attr(n, "representation"),
            coordinate_system,
            component,
            axis,
        });
    }
    Ok(Device {
        id,
        name: attr(dev, "name"),
        uuid: attr(dev, "uuid"),
        items,
        axes,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Trimmed from the Okuma `Devices.xml` of the cppagent demo: namespaced, two position items
    /// (machine and work coordinates via `coordinateSystemIdRef`), a second device.
    const OKUMA: &str = r#"<?xml version="1.0" encoding="utf-8"?>
<MTConnectDevices xmlns="urn:mtconnect.org:MTConnectDevices:2.7">
  <Devices>
    <Device uuid="OKUMA.123456" name="OKUMA" id="OKUMA.123456">
      <Configuration><CoordinateSystems>
        <CoordinateSystem id="machine" type="MACHINE"/>
        <CoordinateSystem id="work" type="OBJECT" parentIdRef="machine"/>
      </CoordinateSystems></Configuration>
      <DataItems>
        <DataItem category="EVENT" id="Lavail" type="AVAILABILITY" name="avail"/>
      </DataItems>
      <Components>
        <Axes name="Axes" id="Laxes1"><Components>
          <Linear name="Z1" id="Lz1">
            <DataItems>
              <DataItem type="POSITION" subType="ACTUAL" category="SAMPLE" name="Z1actm"
                units="MILLIMETER" coordinateSystemIdRef="machine" id="LZ1actm"/>
              <DataItem type="POSITION" subType="ACTUAL" category="SAMPLE" name="Z1actw"
                units="MILLIMETER" coordinateSystemIdRef="work" id="LZ1actw"/>
              <DataItem type="LOAD" category="SAMPLE" name="Z1load" units="PERCENT" id="LZ1load"/>
            </DataItems>
          </Linear>
          <Rotary name="C1" nativeName="S" id="Lc1"/>
        </Components></Axes>
        <Controller id="cont"><DataItems>
          <DataItem category="CONDITION" id="sys" type="SYSTEM" name="system"/>
          <DataItem category="EVENT" id="msg" type="MESSAGE"/>
          <DataItem category="SAMPLE" id="ts" type="DISPLACEMENT" representation="TIME_SERIES"/>
        </DataItems></Controller>
      </Components>
    </Device>
    <Device id="d1" uuid="Mazak" name="Mazak"/>
  </Devices>
</MTConnectDevices>"#;

    #[test]
    fn okuma_items_map_to_their_axis_with_units_and_coordinates() {
        let m = DeviceModel::parse(OKUMA, "Devices.xml").unwrap();
        assert_eq!(m.devices.len(), 2);
        let d = &m.devices[0];
        assert_eq!(d.label(), "OKUMA");
        assert_eq!(d.axes.len(), 2);
        let z = d.find_axis("Z1", "x").unwrap();
        assert_eq!(d.axes[z].items.len(), 3);
        let p = d.find_item("Z1actm").unwrap();
        let it = &d.items[p];
        assert_eq!(it.id, "LZ1actm");
        assert_eq!(it.type_label(), "POSITION:ACTUAL");
        assert_eq!(it.units.as_deref(), Some("MILLIMETER"));
        assert_eq!(it.coordinate_system.as_deref(), Some("MACHINE"));
        assert_eq!(it.axis, Some(z));
        assert_eq!(it.component, "Linear");
        let w = &d.items[d.find_item("Z1actw").unwrap()];
        assert_eq!(w.coordinate_system.as_deref(), Some("OBJECT"));
        // An item without a name is keyed by its id.
        let msg = d.find_item("msg").unwrap();
        assert_eq!(d.items[msg].shape(), Shape::Message);
        assert_eq!(
            d.items[d.find_item("system").unwrap()].shape(),
            Shape::Condition
        );
        assert_eq!(
            d.items[d.find_item("ts").unwrap()].shape(),
            Shape::TimeSeries
        );
        assert_eq!(d.items[d.find_item("avail").unwrap()].axis, None);
        // Axis by nativeName and case-insensitively.
        assert_eq!(d.find_axis("S", "x").unwrap(), 1);
        assert_eq!(d.find_axis("z1", "x").unwrap(), z);
    }

    #[test]
    fn unknown_axis_lists_the_axes() {
        let m = DeviceModel::parse(OKUMA, "Devices.xml").unwrap();
        let e = m.devices[0].find_axis("Q", "Devices.xml").unwrap_err();
        let s = e.to_string();
        assert!(s.contains("no axis `Q`"), "{s}");
        assert!(
            s.contains("Z1 (Linear, id Lz1)") && s.contains("C1 (Rotary"),
            "{s}"
        );
    }

    #[test]
    fn not_xml_and_no_device_are_errors() {
        let e = DeviceModel::parse("this is not <xml", "bad.xml").unwrap_err();
        assert!(matches!(e, ImportError::BadDevices { .. }), "{e}");
        assert!(e.to_string().starts_with("bad.xml: "), "{e}");
        let e = DeviceModel::parse("<MTConnectDevices/>", "empty.xml").unwrap_err();
        assert!(e.to_string().contains("no <Device>"), "{e}");
    }
}
