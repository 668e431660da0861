//! OpenEXR encoding and decoding of [`ImageLayers`]; the file layout and the
//! metadata rules are documented on the parent module.

use super::{ImageLayers, MetaValue};
use anyhow::{Context, Result, bail, ensure};
use exr::prelude::{
    AnyChannel, AnyChannels, AttributeValue, Blocks, Compression, Encoding, FlatSamples, Image,
    Layer, LayerAttributes, LineOrder, MetaData, ReadChannels, ReadLayers, SmallVec, Text,
    WritableImage, read,
};
use std::collections::HashMap;
use std::fs::{self, File, OpenOptions};
use std::io::{Cursor, Write};
use std::path::Path;
use std::sync::atomic::{AtomicU64, Ordering};

const RGB: [&str; 3] = ["R", "G", "B"];
const VARIANCE: [&str; 3] = ["variance.R", "variance.G", "variance.B"];
const SAMPLES: &str = "samples.Y";

/// Refuse to decode more pixels than this (16k x 16k): a corrupt or hostile
/// header must produce an error, not a multi-gigabyte allocation.
const MAX_PIXELS: usize = 1 << 28;

/// Below this many pixels, (de)compress on the calling thread: the `exr`
/// crate builds a fresh thread pool per call, which costs more than it saves
/// on small images.
const PARALLEL_MIN_PIXELS: usize = 1 << 15;

const ENCODING: Encoding = Encoding {
    compression: Compression::ZIP16,
    blocks: Blocks::ScanLines,
    line_order: LineOrder::Increasing,
};

/// Encodes the layers and metadata as an in-memory EXR file.
pub fn encode_exr(img: &ImageLayers, meta: &[(String, MetaValue)]) -> Result<Vec<u8>> {
    img.check()?;
    let mut channels = SmallVec::new();
    for c in 0..3 {
        channels.push(f32_channel(RGB[c], img.rgb.iter().map(|p| p[c])));
        channels.push(f32_channel(VARIANCE[c], img.variance.iter().map(|p| p[c])));
    }
    channels.push(f32_channel(SAMPLES, img.samples.iter().copied()));
    let size = (img.width, img.height);
    let layer = Layer::new(size, layer_attributes(meta)?, ENCODING, AnyChannels::sort(channels));
    let image = Image::from_layer(layer);
    let mut writer = image.write();
    if img.width * img.height < PARALLEL_MIN_PIXELS {
        writer = writer.non_parallel();
    }
    let mut bytes = Vec::new();
    writer.to_buffered(Cursor::new(&mut bytes)).context("encoding EXR")?;
    Ok(bytes)
}

/// Encodes and atomically replaces `path`: temp file in the same directory,
/// fsync, rename, then fsync of the directory so the rename is durable.
pub fn write_exr(path: &Path, img: &ImageLayers, meta: &[(String, MetaValue)]) -> Result<()> {
    let bytes = encode_exr(img, meta)?;
    write_atomically(path, &bytes).with_context(|| format!("writing {}", path.display()))
}

/// Decodes an EXR written by [`encode_exr`] or a plain RGB(A)/Y EXR.
pub fn decode_exr(bytes: &[u8]) -> Result<(ImageLayers, Vec<(String, MetaValue)>)> {
    let image = read_first_layer(bytes)?;
    let layer = &image.layer_data;
    let mut meta = read_meta(&layer.attributes);
    let shared = image.attributes.other.iter();
    meta.extend(shared.filter_map(|(k, v)| meta_entry(k, v)));
    meta.sort_by(|a, b| a.0.cmp(&b.0));
    Ok((image_layers(layer)?, meta))
}

type AnyLayer = Layer<AnyChannels<FlatSamples>>;

/// Reads all channels of the first part, after checking its header so that
/// a hostile size cannot trigger a huge allocation.
fn read_first_layer(bytes: &[u8]) -> Result<Image<AnyLayer>> {
    let header = MetaData::read_from_buffered(bytes, false).context("not a readable EXR file")?;
    let first = header.headers.first().context("EXR file has no parts")?;
    ensure!(!first.deep, "deep EXR files are not supported");
    let (width, height) = (first.layer_size.0, first.layer_size.1);
    let pixels = width.checked_mul(height).filter(|&n| n <= MAX_PIXELS);
    let pixels = pixels.with_context(|| format!("EXR is {width}x{height}: too large"))?;
    let mut reader = read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .first_valid_layer()
        .all_attributes();
    if pixels < PARALLEL_MIN_PIXELS {
        reader = reader.non_parallel();
    }
    reader.from_buffered(Cursor::new(bytes)).context("decoding EXR pixels")
}

fn image_layers(layer: &AnyLayer) -> Result<ImageLayers> {
    let (width, height) = (layer.size.0, layer.size.1);
    let find = |name: &str| channel_values(&layer.channel_data, name, width * height);
    let mut img = ImageLayers::zeroed(width, height);
    let rgb = match (find(RGB[0])?, find(RGB[1])?, find(RGB[2])?, find("Y")?) {
        (Some(r), Some(g), Some(b), _) => [r, g, b],
        (None, None, None, Some(y)) => [y.clone(), y.clone(), y],
        _ => bail!("EXR has no R,G,B or Y channels (found: {})", channel_names(layer)),
    };
    fill(&mut img.rgb, rgb);
    let variance = (find(VARIANCE[0])?, find(VARIANCE[1])?, find(VARIANCE[2])?);
    if let (Some(r), Some(g), Some(b)) = variance {
        fill(&mut img.variance, [r, g, b]);
    }
    if let Some(samples) = find(SAMPLES)? {
        img.samples = samples;
    }
    Ok(img)
}

fn f32_channel(name: &str, values: impl Iterator<Item = f32>) -> AnyChannel<FlatSamples> {
    AnyChannel::new(name, FlatSamples::F32(values.collect()))
}

/// Caller metadata as layer attributes; see the parent module for the rules.
fn layer_attributes(meta: &[(String, MetaValue)]) -> Result<LayerAttributes> {
    let mut attributes = LayerAttributes::default();
    let mut other = HashMap::new();
    for (name, value) in meta {
        ensure!(!name.is_empty(), "metadata name must not be empty");
        let slot = match (name.as_str(), value) {
            ("software", MetaValue::Text(_)) => Some(&mut attributes.software_name),
            ("owner", MetaValue::Text(_)) => Some(&mut attributes.owner),
            ("comments", MetaValue::Text(_)) => Some(&mut attributes.comments),
            ("capDate", MetaValue::Text(_)) => Some(&mut attributes.capture_date),
            _ => None,
        };
        let fresh = match (slot, value) {
            (Some(slot), MetaValue::Text(text)) => slot.replace(utf8_text(text)).is_none(),
            _ => other.insert(utf8_text(name), attribute_value(value)).is_none(),
        };
        ensure!(fresh, "metadata name `{name}` given twice");
    }
    attributes.other = other;
    Ok(attributes)
}

fn attribute_value(value: &MetaValue) -> AttributeValue {
    match value {
        MetaValue::Text(text) => AttributeValue::Text(utf8_text(text)),
        MetaValue::Int(v) => AttributeValue::I32(*v),
        MetaValue::Float(v) => AttributeValue::F32(*v),
        MetaValue::Double(v) => AttributeValue::F64(*v),
    }
}

/// EXR strings are byte strings; UTF-8 is what other tools expect in them.
fn utf8_text(text: &str) -> Text {
    Text::from_slice_unchecked(text.as_bytes())
}

fn string_of(text: &Text) -> String {
    String::from_utf8(text.bytes().to_vec()).unwrap_or_else(|_| text.to_string())
}

fn read_meta(attributes: &LayerAttributes) -> Vec<(String, MetaValue)> {
    let standard = [
        ("software", &attributes.software_name),
        ("owner", &attributes.owner),
        ("comments", &attributes.comments),
        ("capDate", &attributes.capture_date),
    ];
    let standard = standard.into_iter().filter_map(|(name, text)| {
        Some((name.to_owned(), MetaValue::Text(string_of(text.as_ref()?))))
    });
    let other = attributes.other.iter().filter_map(|(k, v)| meta_entry(k, v));
    standard.chain(other).collect()
}

/// Scalar attributes map to [`MetaValue`]; other types (matrices, vectors,
/// chromaticities, ...) are skipped.
fn meta_entry(name: &Text, value: &AttributeValue) -> Option<(String, MetaValue)> {
    let value = match value {
        AttributeValue::Text(text) => MetaValue::Text(string_of(text)),
        AttributeValue::I32(v) => MetaValue::Int(*v),
        AttributeValue::F32(v) => MetaValue::Float(*v),
        AttributeValue::F64(v) => MetaValue::Double(*v),
        _ => return None,
    };
    Some((string_of(name), value))
}

/// The samples of the channel named exactly `name`, as f32, if present.
fn channel_values(
    channels: &AnyChannels<FlatSamples>,
    name: &str,
    n: usize,
) -> Result<Option<Vec<f32>>> {
    let Some(channel) = channels.list.iter().find(|c| c.name.eq(name)) else {
        return Ok(None);
    };
    let values: Vec<f32> = channel.sample_data.values_as_f32().collect();
    ensure!(values.len() == n, "channel `{name}` is subsampled, which is not supported");
    Ok(Some(values))
}

fn channel_names(layer: &AnyLayer) -> String {
    let names: Vec<String> = layer.channel_data.list.iter().map(|c| string_of(&c.name)).collect();
    names.join(", ")
}

fn fill(target: &mut [[f32; 3]], [r, g, b]: [Vec<f32>; 3]) {
    for (i, pixel) in target.iter_mut().enumerate() {
        *pixel = [r[i], g[i], b[i]];
    }
}

/// Writes via a uniquely named hidden temp file so that concurrent writers
/// and crashes never leave a partial file under `path`.
fn write_atomically(path: &Path, bytes: &[u8]) -> Result<()> {
    static COUNTER: AtomicU64 = AtomicU64::new(0);
    let name = path.file_name().context("output path has no file name")?;
    let dir = path.parent().filter(|d| !d.as_os_str().is_empty()).unwrap_or(Path::new("."));
    let unique = (std::process::id(), COUNTER.fetch_add(1, Ordering::Relaxed));
    let temp = dir.join(format!(".{}.{}-{}.tmp", name.to_string_lossy(), unique.0, unique.1));
    let result = write_and_sync(&temp, bytes).and_then(|()| Ok(fs::rename(&temp, path)?));
    if result.is_err() {
        let _ = fs::remove_file(&temp);
    }
    result?;
    // Durability of the rename; not all platforms can open a directory.
    if let Ok(dir) = File::open(dir) {
        let _ = dir.sync_all();
    }
    Ok(())
}

fn write_and_sync(temp: &Path, bytes: &[u8]) -> Result<()> {
    let mut file = OpenOptions::new().write(true).create_new(true).open(temp)?;
    file.write_all(bytes)?;
    file.sync_all()?;
    Ok(())
}

#[cfg(test)]
mod tests;
