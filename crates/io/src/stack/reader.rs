//! Reading a TIFF stack: every page's directory checked first (size, sample type, data
//! within the file), the first slice page's metadata read, the calibration resolved
//! (option, file, default), then the slices decoded one page at a time.

use std::collections::BTreeMap;
use std::fmt;
use std::fs::File;
use std::io::{BufReader, Read, Seek, SeekFrom};
use std::path::Path;

use tiff::ColorType;
use tiff::decoder::{Decoder, DecodingResult, Limits, ifd::Value};
use tiff::tags::Tag;

use super::meta;
use super::{
    MAX_PAGES, MAX_SLICE_PIXELS, PageOrder, ReadStackError, SampleType, Source, Sourced,
    StackError, StackFormat, StackInfo, StackOptions, TAG_CZ_LSMINFO,
};

/// Streams the slices of a TIFF stack.
pub struct StackReader<R: Read + Seek> {
    decoder: Decoder<R>,
    info: StackInfo,
    /// TIFF directory index of each slice, in page order.
    slices: Vec<usize>,
    next: usize,
    buffer: DecodingResult,
    out: Vec<f32>,
}

impl<R: Read + Seek> fmt::Debug for StackReader<R> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("StackReader")
            .field("info", &self.info)
            .field("next", &self.next)
            .finish_non_exhaustive()
    }
}

impl StackReader<BufReader<File>> {
    /// Opens a stack file and checks every page's directory.
    ///
    /// # Errors
    /// [`ReadStackError::Io`] if the file cannot be opened, [`ReadStackError::Format`]
    /// with the [`StackError`] otherwise.
    pub fn open(path: impl AsRef<Path>, options: &StackOptions) -> Result<Self, ReadStackError> {
        let path = path.as_ref();
        let file = File::open(path).map_err(|source| ReadStackError::Io {
            path: path.to_path_buf(),
            source: crate::files::explain_open_error(path, source),
        })?;
        Self::new(BufReader::new(file), options).map_err(|error| ReadStackError::Format {
            path: path.to_path_buf(),
            error,
        })
    }
}

fn tiff_err(page: usize, e: &tiff::TiffError) -> StackError {
    let message = match e {
        tiff::TiffError::IoError(io) if io.kind() == std::io::ErrorKind::UnexpectedEof => {
            "the file ends inside this page's directory or data (truncated?)".to_string()
        }
        e => e.to_string(),
    };
    StackError::Decode { page, message }
}

/// What one slice page looks like.
struct Page {
    size: (usize, usize),
    sample: SampleType,
}

fn rational(v: Option<Value>) -> Option<(u32, u32)> {
    match v? {
        Value::Rational(n, d) => Some((n, d)),
        Value::List(l) => match l.first() {
            Some(Value::Rational(n, d)) => Some((*n, *d)),
            _ => None,
        },
        _ => None,
    }
}

fn ascii(v: Option<Value>) -> Option<String> {
    match v? {
        Value::Ascii(s) => Some(s),
        Value::List(l) => l.into_iter().find_map(|v| match v {
            Value::Ascii(s) => Some(s),
            _ => None,
        }),
        _ => None,
    }
}

impl<R: Read + Seek> StackReader<R> {
    /// Reads the directories of a stack from any seekable source and checks them.
    ///
    /// # Errors
    /// [`StackError`] saying what is wrong and where (page index, field).
    pub fn new(mut reader: R, options: &StackOptions) -> Result<Self, StackError> {
        check_options(options)?;
        let io = |e: std::io::Error| StackError::NotTiff(e.to_string());
        let file_len = reader.seek(SeekFrom::End(0)).map_err(io)?;
        reader.seek(SeekFrom::Start(0)).map_err(io)?;
        let mut decoder = Decoder::new(reader).map_err(|e| match e {
            tiff::TiffError::FormatError(_) if file_len < 8 => {
                StackError::NotTiff(format!("{file_len} bytes is too short for a TIFF header"))
            }
            tiff::TiffError::FormatError(
                f @ (tiff::TiffFormatError::TiffSignatureNotFound
                | tiff::TiffFormatError::TiffSignatureInvalid),
            ) => StackError::NotTiff(f.to_string()),
            e => tiff_err(0, &e),
        })?;
        let mut limits = Limits::default();
        limits.decoding_buffer_size = MAX_SLICE_PIXELS * 4 + (1 << 20);
        limits.ifd_value_size = 16 << 20;
        decoder = decoder.with_limits(limits);

        let Walk {
            slices,
            first,
            mut declared,
            format,
            metadata,
            pages,
        } = walk_pages(&mut decoder, file_len)?;
        check_declared(&mut declared, format, slices.len(), first.size)?;
        let info = stack_info(
            options,
            declared,
            format,
            &first,
            slices.len(),
            pages,
            metadata,
        )?;
        Ok(Self {
            decoder,
            info,
            slices,
            next: 0,
            buffer: DecodingResult::U8(Vec::new()),
            out: Vec::new(),
        })
    }

    /// What the file holds.
    pub fn info(&self) -> &StackInfo {
        &self.info
    }

    /// Index of the next slice [`StackReader::next_slice`] returns (0-based, page order).
    pub fn position(&self) -> usize {
        self.next
    }

    /// Decodes the next slice (page order): `nx · ny` samples, row-major, divided by
    /// [`StackInfo::full_scale`]; `None` after the last slice.
    ///
    /// # Errors
    /// [`StackError::Decode`] (with the page index) when a page cannot be decoded.
    pub fn next_slice(&mut self) -> Result<Option<&[f32]>, StackError> {
        let Some(&page) = self.slices.get(self.next) else {
            return Ok(None);
        };
        let err = |e: tiff::TiffError| tiff_err(page, &e);
        self.decoder.seek_to_image(page).map_err(err)?;
        self.decoder
            .read_image_to_buffer(&mut self.buffer)
            .map_err(err)?;
        let n = self.info.nx * self.info.ny;
        let scale = (1.0 / self.info.full_scale.value) as f32;
        self.out.clear();
        match &self.buffer {
            DecodingResult::U8(v) if v.len() >= n => {
                self.out
                    .extend(v[..n].iter().map(|&x| f32::from(x) * scale));
            }
            DecodingResult::U16(v) if v.len() >= n => {
                self.out
                    .extend(v[..n].iter().map(|&x| f32::from(x) * scale));
            }
            DecodingResult::F32(v) if v.len() >= n => self.out.extend_from_slice(&v[..n]),
            other => {
                return Err(StackError::Decode {
                    page,
                    message: format!(
                        "decoded {} samples of another type or count than the {n} {} samples \
                         expected",
                        other_len(other),
                        self.info.sample
                    ),
                });
            }
        }
        self.next += 1;
        Ok(Some(&self.out))
    }
}

/// The pages of a stack walked: which are slices (reduced-resolution pages skipped),
/// the first slice's size and sample type (every other slice checked against them),
/// and the metadata of the first slice page.
struct Walk {
    /// TIFF directory index of each slice, in page order.
    slices: Vec<usize>,
    first: Page,
    declared: meta::Declared,
    format: StackFormat,
    metadata: BTreeMap<String, String>,
    /// TIFF directories in the file.
    pages: usize,
}

/// Walks every TIFF directory of `decoder` (a file of `file_len` bytes), checking each
/// slice page ([`inspect`]) and reading the first one's metadata ([`read_metadata`]).
fn walk_pages<R: Read + Seek>(decoder: &mut Decoder<R>, file_len: u64) -> Result<Walk, StackError> {
    let mut slices = Vec::new();
    let mut first: Option<Page> = None;
    let mut declared = meta::Declared::default();
    let mut format = StackFormat::PlainTiff;
    let mut metadata = BTreeMap::new();
    let mut page = 0usize;
    loop {
        let subfile: u32 = decoder
            .find_tag_unsigned(Tag::NewSubfileType)
            .map_err(|e| tiff_err(page, &e))?
            .unwrap_or(0);
        let old_subfile: u32 = decoder
            .find_tag_unsigned(Tag::Unknown(255))
            .map_err(|e| tiff_err(page, &e))?
            .unwrap_or(1);
        let reduced = subfile & 1 == 1 || old_subfile == 2;
        if !reduced {
            let this = inspect(decoder, page, file_len)?;
            match &first {
                None => {
                    (format, declared) = read_metadata(decoder, page, &mut metadata)?;
                    first = Some(this);
                }
                Some(f) => {
                    if this.size != f.size {
                        return Err(StackError::PageSize {
                            page,
                            expected: f.size,
                            found: this.size,
                        });
                    }
                    if this.sample != f.sample {
                        return Err(StackError::PageType {
                            page,
                            expected: f.sample,
                            found: this.sample,
                        });
                    }
                }
            }
            slices.push(page);
        }
        if !decoder.more_images() {
            break;
        }
        page += 1;
        if page >= MAX_PAGES {
            return Err(StackError::TooManyPages);
        }
        decoder.next_image().map_err(|e| tiff_err(page, &e))?;
    }
    let pages = page + 1;
    let Some(first) = first else {
        return Err(StackError::TooFewSlices { slices: 0 });
    };
    Ok(Walk {
        slices,
        first,
        declared,
        format,
        metadata,
        pages,
    })
}

/// Checks what the metadata declare against the `nz` slices of `(nx, ny)` found: no
/// channels or time points besides z, the declared slice count and size, at least three
/// slices.
fn check_declared(
    declared: &mut meta::Declared,
    format: StackFormat,
    nz: usize,
    (nx, ny): (usize, usize),
) -> Result<(), StackError> {
    if let Some(what) = declared.extra_dimensions.take() {
        return Err(StackError::Unsupported(format!(
            "{what}: only single-channel, single-time-point z-stacks are read"
        )));
    }
    if let Some((n, field)) = declared.slices {
        if format == StackFormat::ImageJ && nz == 1 && n > 1 {
            return Err(StackError::Unsupported(format!(
                "{field}{n} stored behind a single TIFF directory (ImageJ's layout for \
                 files over 4 GB) is not read; save the stack as OME-TIFF or as a \
                 multi-page TIFF under 4 GB"
            )));
        }
        if n != nz {
            return Err(StackError::DeclaredCount {
                field,
                declared: n,
                found: nz,
            });
        }
    }
    if nz < 3 {
        return Err(StackError::TooFewSlices { slices: nz });
    }
    if let Some((size, field)) = declared.size
        && size != (nx, ny)
    {
        return Err(StackError::DeclaredSize {
            field,
            declared: size,
            found: (nx, ny),
        });
    }
    Ok(())
}

/// What the file holds: the calibration of each quantity from the option when one is
/// given, else from the file, else the default (none for the voxel sizes).
fn stack_info(
    options: &StackOptions,
    declared: meta::Declared,
    format: StackFormat,
    first: &Page,
    nz: usize,
    pages: usize,
    mut metadata: BTreeMap<String, String>,
) -> Result<StackInfo, StackError> {
    let (nx, ny) = first.size;
    let file_value = |v: Option<Result<(f64, String), String>>| match v {
        Some(Ok((x, src))) => Ok(Some(Sourced {
            value: x,
            source: Source::File(src),
        })),
        Some(Err(message)) => Err(StackError::Metadata { format, message }),
        None => Ok(None),
    };
    let pixel_um = match options.pixel_um {
        Some(p) => Some(Sourced {
            value: p,
            source: Source::Option,
        }),
        None => match declared.pixel_um {
            Some(Ok((p, src))) => Some(Sourced {
                value: p,
                source: Source::File(src),
            }),
            Some(Err(message)) => return Err(StackError::Metadata { format, message }),
            None => None,
        },
    };
    let z_step_um = match options.z_step_um {
        Some(z) => Some(Sourced {
            value: z,
            source: Source::Option,
        }),
        None => file_value(declared.z_step_um)?,
    };
    let first_page = match (options.first_page, declared.top_first) {
        (Some(o), _) => Sourced {
            value: o,
            source: Source::Option,
        },
        (None, Some(Ok((top, why)))) => Sourced {
            value: if top {
                PageOrder::TopFirst
            } else {
                PageOrder::BottomFirst
            },
            source: Source::File(why),
        },
        (None, Some(Err(message))) => return Err(StackError::Metadata { format, message }),
        (None, None) => Sourced {
            value: PageOrder::BottomFirst,
            source: Source::Default,
        },
    };
    let full_scale = match (first.sample, declared.full_scale) {
        (SampleType::U16, Some((f, why))) => Sourced {
            value: f,
            source: Source::File(why),
        },
        (SampleType::U8, _) => Sourced {
            value: 255.0,
            source: Source::File("8-bit samples".into()),
        },
        (SampleType::U16, None) => Sourced {
            value: 65535.0,
            source: Source::File("16-bit samples".into()),
        },
        (SampleType::F32, _) => Sourced {
            value: 1.0,
            source: Source::File("float samples are kept as stored".into()),
        },
    };
    metadata.extend(declared.fields);
    Ok(StackInfo {
        format,
        nx,
        ny,
        nz,
        sample: first.sample,
        full_scale,
        pixel_um,
        z_step_um,
        first_page,
        pages,
        skipped_pages: pages - nz,
        metadata,
    })
}

fn other_len(r: &DecodingResult) -> usize {
    match r {
        DecodingResult::U8(v) => v.len(),
        DecodingResult::U16(v) => v.len(),
        DecodingResult::U32(v) => v.len(),
        DecodingResult::U64(v) => v.len(),
        DecodingResult::F16(v) => v.len(),
        DecodingResult::F32(v) => v.len(),
        DecodingResult::F64(v) => v.len(),
        DecodingResult::I8(v) => v.len(),
        DecodingResult::I16(v) => v.len(),
        DecodingResult::I32(v) => v.len(),
        DecodingResult::I64(v) => v.len(),
    }
}

fn check_options(o: &StackOptions) -> Result<(), StackError> {
    let mut values = Vec::new();
    if let Some((dx, dy)) = o.pixel_um {
        values.push(("pixel_um (x)", dx));
        values.push(("pixel_um (y)", dy));
    }
    if let Some(dz) = o.z_step_um {
        values.push(("z_step_um", dz));
    }
    for (name, value) in values {
        if !(value.is_finite() && value > 0.0) {
            return Err(StackError::BadOption {
                name,
                value,
                expected: "finite and > 0 µm",
            });
        }
    }
    Ok(())
}

/// Size, sample type and data extent of the current page.
fn inspect<R: Read + Seek>(
    decoder: &mut Decoder<R>,
    page: usize,
    file_len: u64,
) -> Result<Page, StackError> {
    let (w, h) = decoder.dimensions().map_err(|e| tiff_err(page, &e))?;
    let (nx, ny) = (w as usize, h as usize);
    if nx == 0 || ny == 0 || nx.saturating_mul(ny) > MAX_SLICE_PIXELS {
        return Err(StackError::TooLarge { nx, ny });
    }
    let colour = decoder.colortype().map_err(|e| StackError::Sample {
        page,
        what: e.to_string(),
    })?;
    let format: u16 = decoder
        .find_tag_unsigned_vec::<u16>(Tag::SampleFormat)
        .map_err(|e| tiff_err(page, &e))?
        .and_then(|v| v.first().copied())
        .unwrap_or(1);
    let sample = match (colour, format) {
        (ColorType::Gray(8), 1) => SampleType::U8,
        (ColorType::Gray(16), 1) => SampleType::U16,
        (ColorType::Gray(32), 3) => SampleType::F32,
        (ColorType::Gray(b), f) => {
            let kind = match f {
                1 => "unsigned integer",
                2 => "signed integer",
                3 => "float",
                _ => "untyped",
            };
            return Err(StackError::Sample {
                page,
                what: format!("{b}-bit {kind} samples"),
            });
        }
        (other, _) => {
            return Err(StackError::Sample {
                page,
                what: format!("{other:?} pixels"),
            });
        }
    };
    // Every chunk must lie inside the file; uncompressed strips must hold the page.
    let (offsets_tag, counts_tag) = if decoder
        .find_tag(Tag::TileOffsets)
        .map_err(|e| tiff_err(page, &e))?
        .is_some()
    {
        (Tag::TileOffsets, Tag::TileByteCounts)
    } else {
        (Tag::StripOffsets, Tag::StripByteCounts)
    };
    let get = |d: &mut Decoder<R>, t: Tag| {
        d.find_tag_unsigned_vec::<u64>(t)
            .map_err(|e| tiff_err(page, &e))
    };
    let offsets = get(decoder, offsets_tag)?.unwrap_or_default();
    let counts = get(decoder, counts_tag)?.unwrap_or_default();
    if offsets.is_empty() || offsets.len() != counts.len() {
        return Err(StackError::Decode {
            page,
            message: format!(
                "{} {offsets_tag:?} but {} {counts_tag:?}",
                offsets.len(),
                counts.len()
            ),
        });
    }
    let mut total = 0u64;
    for (&o, &c) in offsets.iter().zip(&counts) {
        let end = o.saturating_add(c);
        if end > file_len {
            return Err(StackError::Truncated {
                page,
                end,
                file_len,
            });
        }
        total = total.saturating_add(c);
    }
    let compression: u16 = decoder
        .find_tag_unsigned(Tag::Compression)
        .map_err(|e| tiff_err(page, &e))?
        .unwrap_or(1);
    let needed = (nx * ny * sample.bytes()) as u64;
    if compression == 1 && offsets_tag == Tag::StripOffsets && total < needed {
        return Err(StackError::ShortData {
            page,
            found: total,
            needed,
            what: format!("{nx} x {ny} {sample}"),
        });
    }
    Ok(Page {
        size: (nx, ny),
        sample,
    })
}

/// The metadata convention of the first slice page and what it declares.
fn read_metadata<R: Read + Seek>(
    decoder: &mut Decoder<R>,
    page: usize,
    fields: &mut BTreeMap<String, String>,
) -> Result<(StackFormat, meta::Declared), StackError> {
    let err = |e: tiff::TiffError| tiff_err(page, &e);
    let description = ascii(decoder.find_tag(Tag::ImageDescription).map_err(err)?);
    let xres = rational(decoder.find_tag(Tag::XResolution).map_err(err)?);
    let yres = rational(decoder.find_tag(Tag::YResolution).map_err(err)?);
    let unit: Option<u16> = decoder
        .find_tag_unsigned(Tag::ResolutionUnit)
        .map_err(err)?;
    let per = |r: Option<(u32, u32)>| {
        r.filter(|r| r.1 != 0)
            .map(|(n, d)| f64::from(n) / f64::from(d))
    };
    if let Some(r) = per(xres) {
        fields.insert("tiff.XResolution".into(), r.to_string());
        fields.insert(
            "tiff.ResolutionUnit".into(),
            match unit.unwrap_or(2) {
                1 => "none",
                2 => "inch",
                3 => "centimetre",
                _ => "unknown",
            }
            .into(),
        );
    }
    if let Some(lsm) = decoder
        .find_tag(Tag::Unknown(TAG_CZ_LSMINFO))
        .map_err(err)?
    {
        let bytes = lsm.into_u8_vec().map_err(|e| StackError::Metadata {
            format: StackFormat::Lsm,
            message: format!("tag 34412 (CZ_LSMINFO) is not a byte record: {e}"),
        })?;
        let d = meta::lsm(&bytes).map_err(|message| StackError::Metadata {
            format: StackFormat::Lsm,
            message,
        })?;
        return Ok((StackFormat::Lsm, d));
    }
    let Some(text) = description else {
        return Ok((StackFormat::PlainTiff, meta::Declared::default()));
    };
    if meta::is_ome(&text) {
        let d = meta::ome(&text).map_err(|message| {
            if message.contains("images (series)") {
                StackError::Unsupported(message)
            } else {
                StackError::Metadata {
                    format: StackFormat::OmeTiff,
                    message,
                }
            }
        })?;
        return Ok((StackFormat::OmeTiff, d));
    }
    if meta::is_imagej(&text) {
        let d = meta::imagej(&text, xres, yres);
        return Ok((StackFormat::ImageJ, d));
    }
    fields.insert(
        "tiff.ImageDescription".into(),
        text.chars().take(200).collect(),
    );
    Ok((StackFormat::PlainTiff, meta::Declared::default()))
}
