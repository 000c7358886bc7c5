use ::image::{ImageBuffer, Luma, Rgb};
use plumbline_testkit::images::{png_bomb, png_claiming};

use super::*;

fn encode(img: DynamicImage, format: ImageFormat) -> Vec<u8> {
    let mut out = Cursor::new(Vec::new());
    img.write_to(&mut out, format).unwrap();
    out.into_inner()
}

fn png_rgb(w: u32, h: u32, f: impl Fn(u32, u32) -> [u8; 3]) -> Vec<u8> {
    encode(DynamicImage::ImageRgb8(ImageBuffer::from_fn(w, h, |x, y| Rgb(f(x, y)))), ImageFormat::Png)
}

fn png_gray(w: u32, h: u32, f: impl Fn(u32, u32) -> u8) -> Vec<u8> {
    encode(DynamicImage::ImageLuma8(ImageBuffer::from_fn(w, h, |x, y| Luma([f(x, y)]))), ImageFormat::Png)
}

const ANY: Bounds = Bounds::budget(PANORAMA_PIXELS);

#[test]
fn the_header_gives_size_and_format_without_decoding() {
    let png = png_rgb(6, 4, |_, _| [1, 2, 3]);
    let h = header("a.png", &png, &ANY).unwrap();
    assert_eq!((h.width, h.height, h.format, h.buffer_bytes), (6, 4, ImageFormat::Png, 6 * 4 * 3));
    let jpeg = encode(DynamicImage::ImageRgb8(ImageBuffer::from_pixel(40, 30, Rgb([9, 9, 9]))), ImageFormat::Jpeg);
    let h = header("a.jpg", &jpeg, &ANY).unwrap();
    assert_eq!((h.width, h.height, h.format), (40, 30, ImageFormat::Jpeg));
}

/// A 20000² PNG of a few bytes. Its pixels cannot even be decoded (its data is empty), so the
/// refusal naming the budget proves that the header was checked before any decoding.
#[test]
fn a_forged_header_over_the_budget_is_refused_before_decoding_naming_file_size_and_budget() {
    let forged = png_claiming(20_000, 20_000);
    let e = decode("pano/bomb.png", &forged, &ANY).unwrap_err();
    assert!(matches!(e, DecodeError::OverBudget { width: 20_000, height: 20_000, .. }), "{e}");
    assert!(e.is_size());
    let msg = e.to_string();
    for part in ["pano/bomb.png: ", "20000 × 20000 px", "400.0 M px", "134.2 M px", "134217728 px"] {
        assert!(msg.contains(part), "{part:?} in {msg}");
    }
    assert!(matches!(decode_gray("b.png", &forged, &ANY), Err(DecodeError::OverBudget { .. })));
    assert!(matches!(decode_mask("b.png", &forged, &ANY), Err(DecodeError::OverBudget { .. })));
    // Admitted by the budget, the same bytes are what they are: a broken PNG.
    let unread = decode("pano/bomb.png", &forged, &Bounds::budget(u64::MAX)).unwrap_err();
    assert!(matches!(unread, DecodeError::Unreadable { .. }), "{unread}");
    assert!(!unread.is_size());
}

/// A real decompression bomb (12000² zeros, 144 MB of pixels in 140 KB) is refused by its header, and the
/// limits stop a decoder whose output would exceed what its header was checked for.
#[test]
fn a_real_decompression_bomb_is_refused_and_the_limits_are_a_second_guard() {
    let bomb = png_bomb(12_000, 12_000);
    assert!(bomb.len() < 1 << 20, "{} bytes", bomb.len());
    let budget = Bounds::budget(64_000_000);
    let e = decode_gray("bomb.png", &bomb, &budget).unwrap_err();
    assert!(matches!(e, DecodeError::OverBudget { width: 12_000, height: 12_000, max_pixels: 64_000_000, .. }));
    assert!(e.to_string().contains("144.0 M px"), "{e}");
    // A header checked as 1000 × 1000 px: the decoder may not go beyond it.
    let h = header("bomb.png", &bomb, &Bounds::budget(u64::MAX)).unwrap();
    let lied = Header { width: 1_000, height: 1_000, buffer_bytes: 1_000_000, ..h };
    let e = decode_checked("bomb.png", &bomb, &lied).unwrap_err();
    assert!(matches!(&e, DecodeError::Unreadable { source: ImageError::Limits(_), .. }), "{e}");
    // Even admitting every size, the allocation is limited to the buffer the header implies plus the slack.
    let mut tight = limits(&h);
    assert_eq!(tight.max_alloc, Some(144_000_000 + DECODER_SLACK_BYTES));
    tight.max_alloc = Some(1 << 20);
    let mut reader = ImageReader::with_format(Cursor::new(&bomb[..]), ImageFormat::Png);
    reader.limits(tight);
    assert!(matches!(reader.decode(), Err(ImageError::Limits(_))));
}

#[test]
fn a_size_other_than_expected_is_refused_and_the_expected_one_decodes() {
    let png = png_gray(8, 5, |x, y| (x + 10 * y) as u8);
    let e = decode("mask.png", &png, &ANY.expecting(16, 8)).unwrap_err();
    assert!(matches!(e, DecodeError::Size { width: 8, height: 5, expected_width: 16, expected_height: 8, .. }));
    assert_eq!(e.to_string(), "mask.png: 8 × 5 px, expected 16 × 8 px");
    let img = decode("mask.png", &png, &ANY.expecting(8, 5)).unwrap();
    assert_eq!((img.width(), img.height()), (8, 5));
    // The budget is checked first and is inclusive.
    assert!(decode("mask.png", &png, &Bounds::budget(40)).is_ok());
    let e = decode("mask.png", &png, &Bounds::budget(39).expecting(8, 5)).unwrap_err();
    assert!(matches!(e, DecodeError::OverBudget { .. }), "{e}");
}

#[test]
fn an_empty_size_is_refused() {
    let e = check("x.png", 0, 5, &ANY).unwrap_err();
    assert!(matches!(e, DecodeError::Empty { width: 0, height: 5, .. }) && e.is_size(), "{e}");
}

#[test]
fn a_required_format_refuses_another_and_garbage_is_unreadable() {
    let jpeg = encode(DynamicImage::ImageLuma8(ImageBuffer::from_pixel(8, 8, Luma([7]))), ImageFormat::Jpeg);
    let e = decode("d.png", &jpeg, &ANY.only(ImageFormat::Png)).unwrap_err();
    assert_eq!(e.to_string(), "d.png: a JPEG image, expected PNG");
    assert!(decode("d.jpg", &jpeg, &ANY.only(ImageFormat::Jpeg)).is_ok());
    let e = decode("dir/broken.jpg", b"not an image", &ANY).unwrap_err();
    assert!(matches!(e, DecodeError::Unreadable { .. }), "{e}");
    assert!(e.to_string().starts_with("dir/broken.jpg: not a readable image: "), "{e}");
    // A PNG cut after its header: the header passes, the pixels are not there.
    let png = png_rgb(64, 64, |x, y| [x as u8, y as u8, 0]);
    let e = decode("cut.png", &png[..png.len() / 2], &ANY).unwrap_err();
    assert!(matches!(e, DecodeError::Unreadable { .. }), "{e}");
}

/// The tight limits admit every colour type the PNG and JPEG decoders produce.
#[test]
fn every_colour_type_decodes_within_its_own_limits() {
    let (w, h) = (37, 23);
    let images = [
        DynamicImage::ImageLuma8(ImageBuffer::from_fn(w, h, |x, _| Luma([x as u8]))),
        DynamicImage::ImageLuma16(ImageBuffer::from_fn(w, h, |x, y| Luma([(x * 1000 + y) as u16]))),
        DynamicImage::ImageRgb8(ImageBuffer::from_fn(w, h, |x, y| Rgb([x as u8, y as u8, 5]))),
        DynamicImage::ImageRgb16(ImageBuffer::from_fn(w, h, |x, y| Rgb([x as u16, y as u16, 5]))),
        DynamicImage::ImageRgba16(ImageBuffer::from_fn(w, h, |x, y| ::image::Rgba([x as u16, y as u16, 5, 9]))),
    ];
    for img in images {
        let png = encode(img.clone(), ImageFormat::Png);
        assert_eq!(decode("c.png", &png, &ANY.expecting(w, h)).unwrap(), img, "{:?}", img.color());
    }
    let jpeg = encode(DynamicImage::ImageRgb8(ImageBuffer::from_pixel(w, h, Rgb([90, 60, 30]))), ImageFormat::Jpeg);
    assert_eq!(decode("c.jpg", &jpeg, &ANY.expecting(w, h)).unwrap().color(), ::image::ColorType::Rgb8);
    // A large, legitimate grey PNG (4000² zeros, 16 MB of pixels) decodes within its limits.
    let big = png_bomb(4_000, 4_000);
    let g = decode_gray("big.png", &big, &ANY.expecting(4_000, 4_000)).unwrap();
    assert_eq!((g.width(), g.height(), g.get(3_999, 3_999)), (4_000, 4_000, 0.0));
}

#[test]
fn gray_is_the_luma_of_the_pixel_at_the_same_place_and_grey_input_takes_the_same_path() {
    let png = png_rgb(6, 4, |x, y| [(10 * x) as u8, (20 * y) as u8, 200]);
    let g = decode_gray("a.png", &png, &ANY).unwrap();
    assert_eq!((g.width(), g.height()), (6, 4));
    let expect = 0.299 * 50.0 + 0.587 * 60.0 + 0.114 * 200.0;
    assert!((g.get(5, 3) - expect).abs() < 1e-4, "{}", g.get(5, 3));
    // 8-bit grey skips the RGB copy and gives the same values as its RGB equivalent, to the bit.
    let f = |x: u32, y: u32| (17 * x + 41 * y) as u8;
    let from_gray = decode_gray("g.png", &png_gray(6, 4, f), &ANY).unwrap();
    let from_rgb = decode_gray("g.png", &png_rgb(6, 4, |x, y| [f(x, y); 3]), &ANY).unwrap();
    assert_eq!(from_gray, from_rgb);
}

/// A panorama decoded to a part: a YCbCr JPEG goes straight to its luma plane and agrees with the full
/// RGB decode's luma within JPEG rounding; the rows and the column means are those of the part; a PNG
/// takes the full decoder; a file of another size is refused on its header.
#[test]
fn a_part_is_decoded_to_the_rows_and_column_means_it_names() {
    let (w, h) = (64, 32);
    let rgb = |x: u32, y: u32| [(4 * x) as u8, (7 * y) as u8, ((x * y) % 251) as u8];
    let img = DynamicImage::ImageRgb8(ImageBuffer::from_fn(w, h, |x, y| Rgb(rgb(x, y))));
    let jpeg = encode(img, ImageFormat::Jpeg);
    let full = decode_gray("p.jpg", &jpeg, &ANY).unwrap();
    let whole = decode_gray_part("p.jpg", &jpeg, &ANY, &ImagePart::whole(w, h)).unwrap();
    // They differ where the RGB decode clamps a saturated colour: little on average, a few levels at most.
    let diff: Vec<f32> = full.data().iter().zip(whole.data()).map(|(a, b)| (a - b).abs()).collect();
    let (worst, mean) = (diff.iter().copied().fold(0.0, f32::max), diff.iter().sum::<f32>() / diff.len() as f32);
    assert!(
        worst <= 8.0 && mean < 0.75,
        "luma plane and luma of the RGB decode differ by {mean} on average, {worst} at most"
    );
    let part = ImagePart::new(w, h, 20, 4).unwrap();
    let cut = decode_gray_part("p.jpg", &jpeg, &ANY, &part).unwrap();
    assert_eq!((cut.width(), cut.height()), (16, 12));
    let mean = (0..4).map(|k| whole.get(5 * 4 + k, 20 + 7)).sum::<f32>() / 4.0;
    assert!((cut.get(5, 7) - mean).abs() < 1e-4, "{} vs {mean}", cut.get(5, 7));
    let png = png_rgb(w, h, rgb);
    let from_png = decode_gray_part("p.png", &png, &ANY, &part).unwrap();
    let png_whole = decode_gray("p.png", &png, &ANY).unwrap();
    assert_eq!(from_png, part.extract(png_whole.data()).unwrap());
    let wrong = decode_gray_part("p.jpg", &jpeg, &ANY, &ImagePart::whole(128, 64)).unwrap_err();
    assert!(matches!(wrong, DecodeError::Size { .. }), "{wrong}");
    let bomb = decode_gray_part("b.png", &png_claiming(20_000, 20_000), &ANY, &ImagePart::whole(20_000, 20_000));
    assert!(matches!(bomb, Err(DecodeError::OverBudget { .. })));
}

#[test]
fn a_mask_marks_non_zero_pixels() {
    let png = png_rgb(4, 2, |x, y| if y == 1 && x >= 2 { [255, 255, 255] } else { [0, 0, 0] });
    let m = decode_mask("mask.png", &png, &ANY.expecting(4, 2)).unwrap();
    assert_eq!(m.count(), 2);
    assert!(m.get(3, 1) && !m.get(0, 0));
    let m = decode_mask("mask.png", &png_gray(3, 3, |x, _| u8::from(x == 1)), &ANY).unwrap();
    assert_eq!(m.count(), 3);
}
