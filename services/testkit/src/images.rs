//! Hostile images for the decoders' pixel budgets: PNGs whose header claims far more pixels than their
//! bytes hold.

use std::io::Write as _;

/// PNG signature.
const SIGNATURE: [u8; 8] = [0x89, b'P', b'N', b'G', b'\r', b'\n', 0x1a, b'\n'];

/// CRC-32 (ISO-HDLC, the PNG chunk checksum), bitwise: the chunks here are a few bytes long.
fn crc32(bytes: &[u8]) -> u32 {
    let mut crc = 0xFFFF_FFFFu32;
    for &b in bytes {
        crc ^= u32::from(b);
        for _ in 0..8 {
            crc = if crc & 1 == 1 { (crc >> 1) ^ 0xEDB8_8320 } else { crc >> 1 };
        }
    }
    !crc
}

/// One chunk: length, type, data, CRC over type and data.
fn chunk(out: &mut Vec<u8>, kind: &[u8; 4], data: &[u8]) {
    let length = u32::try_from(data.len()).expect("a chunk below 4 GiB");
    out.extend_from_slice(&length.to_be_bytes());
    let start = out.len();
    out.extend_from_slice(kind);
    out.extend_from_slice(data);
    let crc = crc32(&out[start..]);
    out.extend_from_slice(&crc.to_be_bytes());
}

/// A forged 8-bit greyscale PNG whose IHDR (with a correct CRC) claims `width` × `height` pixels, followed
/// by a tiny IDAT (one empty stored deflate block, a valid zlib stream of nothing) and IEND: 68 bytes that a
/// decoder reading the header first must refuse before allocating anything. Decoding it fails (the data
/// ends early), so only a header check can tell a budget from a broken file.
pub fn png_claiming(width: u32, height: u32) -> Vec<u8> {
    let mut out = SIGNATURE.to_vec();
    let mut ihdr = Vec::with_capacity(13);
    ihdr.extend_from_slice(&width.to_be_bytes());
    ihdr.extend_from_slice(&height.to_be_bytes());
    // Bit depth 8, colour type 0 (greyscale), deflate, adaptive filtering, no interlace.
    ihdr.extend_from_slice(&[8, 0, 0, 0, 0]);
    chunk(&mut out, b"IHDR", &ihdr);
    // zlib header (deflate, 32 KiB window, no dictionary), a final stored block of length 0, Adler-32 of "".
    chunk(&mut out, b"IDAT", &[0x78, 0x01, 0x01, 0x00, 0x00, 0xFF, 0xFF, 0x00, 0x00, 0x00, 0x01]);
    chunk(&mut out, b"IEND", &[]);
    out
}

/// A real decompression bomb: a valid 8-bit greyscale PNG of `width` × `height` black pixels, encoded by
/// streaming one row at a time (the encoder never holds the image). 12000 × 12000 is about 140 KB of file
/// for 144 MB of pixels (576 MB once converted to f32).
pub fn png_bomb(width: u32, height: u32) -> Vec<u8> {
    let mut out = Vec::new();
    let mut encoder = png::Encoder::new(&mut out, width, height);
    encoder.set_color(png::ColorType::Grayscale);
    encoder.set_depth(png::BitDepth::Eight);
    encoder.set_compression(png::Compression::Balanced);
    encoder.set_filter(png::Filter::NoFilter);
    let mut writer = encoder.write_header().expect("a PNG header in memory");
    let mut stream = writer.stream_writer().expect("a PNG stream in memory");
    let row = vec![0u8; width as usize];
    for _ in 0..height {
        stream.write_all(&row).expect("a PNG row in memory");
    }
    stream.finish().expect("the PNG's last row in memory");
    writer.finish().expect("the PNG's end in memory");
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_crc_is_the_png_one() {
        // The IEND chunk's CRC is the same in every PNG.
        assert_eq!(crc32(b"IEND"), 0xAE42_6082);
        assert_eq!(crc32(b"123456789"), 0xCBF4_3926);
    }

    /// The PNG decoder reads both headers (so every CRC is right) and finds the size they claim.
    fn info(png: &[u8]) -> (u32, u32) {
        let reader = png::Decoder::new(std::io::Cursor::new(png)).read_info().expect("a readable PNG header");
        (reader.info().width, reader.info().height)
    }

    #[test]
    fn the_forged_header_claims_its_size_in_68_bytes() {
        let png = png_claiming(20_000, 20_000);
        assert_eq!(png.len(), 68);
        assert_eq!(info(&png), (20_000, 20_000));
    }

    #[test]
    fn the_bomb_is_small_and_decodes_to_what_it_claims() {
        let t0 = std::time::Instant::now();
        let bomb = png_bomb(12_000, 12_000);
        eprintln!("12000² bomb: {} bytes in {:?}", bomb.len(), t0.elapsed());
        assert!(bomb.len() < 300_000, "{} bytes", bomb.len());
        assert_eq!(info(&bomb), (12_000, 12_000));
        let small = png_bomb(300, 200);
        let mut reader = png::Decoder::new(std::io::Cursor::new(&small[..])).read_info().unwrap();
        let mut pixels = vec![1; reader.output_buffer_size().unwrap()];
        reader.next_frame(&mut pixels).unwrap();
        assert_eq!(pixels.len(), 300 * 200);
        assert!(pixels.iter().all(|&p| p == 0));
    }
}
