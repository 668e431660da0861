//! Tests of the EXR round trip, file layout, foreign files and robustness.

use super::*;
use ::exr::prelude::{
    AnyChannel, AnyChannels, AttributeValue, Blocks, Compression, Encoding, FlatSamples, Image,
    Layer, LayerAttributes, LineOrder, MetaData, SampleType, SmallVec, Text, WritableImage, f16,
};
use std::io::Cursor;

/// An image whose values include every f32 class (NaN with payload, ±Inf,
/// -0, subnormal, max) and whose height spans several 16-line ZIP blocks.
fn sample_image() -> ImageLayers {
    let (width, height) = (5, 37);
    let mut img = ImageLayers::zeroed(width, height);
    let special =
        [f32::from_bits(0x7fc0_1234), f32::INFINITY, f32::NEG_INFINITY, -0.0, 1e-42, f32::MAX];
    for i in 0..width * height {
        let v = |k: usize| special.get((i + k) % 40).copied().unwrap_or((i * 7 + k) as f32 * 0.013);
        img.rgb[i] = [v(0), v(1), v(2)];
        img.variance[i] = [v(3) * 1e-3, v(4), v(5)];
        img.samples[i] = (i % 9) as f32 * 64.0;
    }
    img
}

fn sample_meta() -> Vec<(String, MetaValue)> {
    let mut meta = vec![
        ("capDate".to_owned(), MetaValue::Text("2025:01:02 03:04:05".into())),
        ("software".to_owned(), MetaValue::Text("tessera 0.1.0".into())),
        ("tessera.empty".to_owned(), MetaValue::Text(String::new())),
        ("tessera.nan".to_owned(), MetaValue::Float(f32::from_bits(0x7fc0_0042))),
        ("tessera.scene".to_owned(), MetaValue::Text("café ✓ / naïve".into())),
        ("tessera.seconds".to_owned(), MetaValue::Double(1_234.567_890_123)),
        ("tessera.sobol.seed.with.a.name.longer.than.31".to_owned(), MetaValue::Int(-7)),
        ("tessera.spp".to_owned(), MetaValue::Int(4096)),
        ("tessera.time".to_owned(), MetaValue::Float(0.1)),
    ];
    meta.sort_by(|a, b| a.0.cmp(&b.0));
    meta
}

fn bits(layers: &ImageLayers) -> Vec<u32> {
    let rgb = layers.rgb.iter().chain(&layers.variance).flatten();
    rgb.chain(&layers.samples).map(|v| v.to_bits()).collect()
}

/// Metadata with floats replaced by their bits, so NaN compares equal.
fn meta_bits(meta: &[(String, MetaValue)]) -> Vec<(String, String)> {
    let show = |v: &MetaValue| match v {
        MetaValue::Float(f) => format!("f32 {:#x}", f.to_bits()),
        MetaValue::Double(f) => format!("f64 {:#x}", f.to_bits()),
        other => format!("{other:?}"),
    };
    meta.iter().map(|(k, v)| (k.clone(), show(v))).collect()
}

#[test]
fn round_trip_preserves_every_bit() {
    let (img, meta) = (sample_image(), sample_meta());
    let (back, back_meta) = decode_exr(&encode_exr(&img, &meta).unwrap()).unwrap();
    assert_eq!((back.width, back.height), (img.width, img.height));
    assert_eq!(bits(&back), bits(&img));
    assert_eq!(meta_bits(&back_meta), meta_bits(&meta));
}

#[test]
fn file_layout_is_as_documented() {
    let bytes = encode_exr(&sample_image(), &sample_meta()).unwrap();
    let file = MetaData::read_from_buffered(bytes.as_slice(), true).unwrap();
    assert_eq!(file.headers.len(), 1);
    let header = &file.headers[0];
    let names: Vec<String> = header.channels.list.iter().map(|c| c.name.to_string()).collect();
    // OpenEXR stores channels sorted by name.
    let expected = ["B", "G", "R", "samples.Y", "variance.B", "variance.G", "variance.R"];
    assert_eq!(names, expected);
    assert!(header.channels.list.iter().all(|c| c.sample_type == SampleType::F32));
    assert_eq!(header.compression, Compression::ZIP16);
    assert_eq!(header.blocks, ::exr::meta::BlockDescription::ScanLines);
    assert_eq!(header.line_order, LineOrder::Increasing);
    let spp = header.own_attributes.other.get(&Text::from("tessera.spp"));
    assert_eq!(spp, Some(&AttributeValue::I32(4096)));
    let software = header.own_attributes.software_name.as_ref().map(Text::to_string);
    assert_eq!(software.as_deref(), Some("tessera 0.1.0"));
}

#[test]
fn encode_rejects_inconsistent_input() {
    let mut img = sample_image();
    img.samples.pop();
    assert!(encode_exr(&img, &[]).is_err());
    assert!(encode_exr(&ImageLayers::zeroed(0, 3), &[]).is_err());
    let img = sample_image();
    let reserved = [("compression".to_owned(), MetaValue::Int(1))];
    assert!(encode_exr(&img, &reserved).unwrap_err().to_string().contains("EXR"));
    let twice = [("a".to_owned(), MetaValue::Int(1)), ("a".to_owned(), MetaValue::Float(1.0))];
    assert!(encode_exr(&img, &twice).unwrap_err().to_string().contains("twice"));
}

/// A foreign-style file: half-float RGBA, tiled, PIZ, with a Mitsuba-style
/// text attribute, as written by renderers other than ours.
fn foreign_exr(names: &[&str]) -> Vec<u8> {
    let (w, h) = (19, 11);
    let channel = |k: usize, name: &&str| {
        let values = (0..w * h).map(|i| f16::from_f32((i * (k + 1)) as f32 / 64.0)).collect();
        AnyChannel::new(*name, FlatSamples::F16(values))
    };
    let channels: SmallVec<_> = names.iter().enumerate().map(|(k, n)| channel(k, n)).collect();
    let mut attributes = LayerAttributes::default();
    attributes.other.insert(
        Text::from("generatedBy"),
        AttributeValue::Text(Text::from("Mitsuba version 3.5.0")),
    );
    let blocks = Blocks::Tiles((8, 8).into());
    let encoding =
        Encoding { compression: Compression::PIZ, blocks, line_order: LineOrder::Unspecified };
    let layer = Layer::new((w, h), attributes, encoding, AnyChannels::sort(channels));
    let mut bytes = Vec::new();
    Image::from_layer(layer).write().to_buffered(Cursor::new(&mut bytes)).unwrap();
    bytes
}

#[test]
fn reads_plain_rgba_and_luminance_files() {
    let (img, meta) = decode_exr(&foreign_exr(&["R", "G", "B", "A"])).unwrap();
    assert_eq!((img.width, img.height), (19, 11));
    let i = 5 * 19 + 3;
    assert_eq!(img.rgb[i], [i as f32 / 64.0, 2.0 * i as f32 / 64.0, 3.0 * i as f32 / 64.0]);
    assert!(img.variance.iter().flatten().chain(&img.samples).all(|&v| v == 0.0));
    assert_eq!(meta, [("generatedBy".to_owned(), MetaValue::Text("Mitsuba version 3.5.0".into()))]);

    let (img, _) = decode_exr(&foreign_exr(&["Y"])).unwrap();
    assert_eq!(img.rgb[7], [7.0 / 64.0; 3]);

    let err = decode_exr(&foreign_exr(&["Z", "depth.V"])).unwrap_err().to_string();
    assert!(err.contains("found: Z, depth.V"), "{err}");
}

#[test]
fn garbage_and_truncated_input_is_an_error_not_a_panic() {
    let good = encode_exr(&sample_image(), &sample_meta()).unwrap();
    assert!(decode_exr(&[]).is_err());
    assert!(decode_exr(b"definitely not an EXR file").is_err());
    assert!(decode_exr(&[0x76, 0x2f, 0x31, 0x01, 2, 0, 0, 0, 0xff, 0xff]).is_err());
    for len in 0..good.len() {
        assert!(decode_exr(&good[..len]).is_err(), "truncated to {len} bytes");
    }
    // Flipped bytes may or may not decode, but must never panic.
    for i in 0..good.len() {
        let mut bad = good.clone();
        bad[i] ^= 0xa5;
        let _ = decode_exr(&bad);
    }
}

#[test]
fn write_exr_replaces_the_target_atomically() {
    let dir = std::env::temp_dir().join(format!("tessera-output-test-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("frame.exr");
    std::fs::write(&path, b"old contents").unwrap();
    let img = sample_image();
    write_exr(&path, &img, &sample_meta()).unwrap();
    let (back, _) = decode_exr(&std::fs::read(&path).unwrap()).unwrap();
    assert_eq!(bits(&back), bits(&img));
    let entries: Vec<_> =
        std::fs::read_dir(&dir).unwrap().map(|e| e.unwrap().file_name()).collect();
    assert_eq!(entries, ["frame.exr"], "no temp files left behind");

    // Failures leave neither a target nor a temp file behind.
    let missing = dir.join("no-such-dir").join("frame.exr");
    assert!(write_exr(&missing, &img, &[]).is_err());
    let occupied = dir.join("occupied");
    std::fs::create_dir_all(occupied.join("child")).unwrap();
    assert!(write_exr(&occupied, &img, &[]).is_err());
    let entries: Vec<_> =
        std::fs::read_dir(&dir).unwrap().map(|e| e.unwrap().file_name()).collect();
    assert_eq!(entries.len(), 2, "{entries:?}");
    std::fs::remove_dir_all(&dir).unwrap();
}
