//! A report as a list of blocks, written as Markdown and as a self-contained HTML page
//! with the same content (images inlined by the caller as data URIs), so that the two
//! cannot drift apart.

use std::fmt::Write as _;

/// One block of a report.
#[derive(Debug, Clone, PartialEq)]
pub enum Block {
    /// A heading of level 1–3.
    Heading(u8, String),
    /// A paragraph (plain text; `code` spans in backticks are kept as code).
    Para(String),
    /// A bulleted list.
    List(Vec<String>),
    /// A table: header and rows of cells.
    Table(Vec<String>, Vec<Vec<String>>),
    /// An image file of the report (a path relative to the report) and its caption.
    Image(String, String),
}

/// A report.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Document {
    /// The blocks in order.
    pub blocks: Vec<Block>,
}

fn md_cell(s: &str) -> String {
    s.replace('|', "\\|").replace('\n', " ")
}

fn html_escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// Text with `code` spans as HTML.
fn html_text(s: &str) -> String {
    let mut out = String::new();
    for (k, part) in s.split('`').enumerate() {
        if k % 2 == 1 {
            let _ = write!(out, "<code>{}</code>", html_escape(part));
        } else {
            out.push_str(&html_escape(part));
        }
    }
    out
}

impl Document {
    /// Adds a block.
    pub fn push(&mut self, b: Block) {
        self.blocks.push(b);
    }

    /// The image files the document shows, in order.
    #[must_use]
    pub fn images(&self) -> Vec<&str> {
        self.blocks
            .iter()
            .filter_map(|b| match b {
                Block::Image(f, _) => Some(f.as_str()),
                _ => None,
            })
            .collect()
    }

    /// The document as Markdown (images linked by their relative path).
    #[must_use]
    pub fn to_markdown(&self) -> String {
        let mut s = String::new();
        for b in &self.blocks {
            match b {
                Block::Heading(l, t) => {
                    let _ = writeln!(s, "{} {t}\n", "#".repeat(usize::from(*l)));
                }
                Block::Para(t) => {
                    let _ = writeln!(s, "{t}\n");
                }
                Block::List(items) => {
                    for i in items {
                        let _ = writeln!(s, "* {i}");
                    }
                    s.push('\n');
                }
                Block::Table(h, rows) => {
                    let _ = writeln!(
                        s,
                        "| {} |",
                        h.iter().map(|c| md_cell(c)).collect::<Vec<_>>().join(" | ")
                    );
                    let _ = writeln!(s, "|{}", " --- |".repeat(h.len()));
                    for r in rows {
                        let _ = writeln!(
                            s,
                            "| {} |",
                            r.iter().map(|c| md_cell(c)).collect::<Vec<_>>().join(" | ")
                        );
                    }
                    s.push('\n');
                }
                Block::Image(f, cap) => {
                    let _ = writeln!(s, "![{}]({f})\n\n*{cap}*\n", md_cell(cap));
                }
            }
        }
        s
    }

    /// The document as one HTML page with no external resource: `image(file)` gives the
    /// `src` of each image (a `data:` URI); an image it has no data for is named instead.
    #[must_use]
    pub fn to_html(&self, title: &str, image: &dyn Fn(&str) -> Option<String>) -> String {
        let mut s = String::new();
        let _ = write!(
            s,
            "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n<title>{}</title>\n\
             <style>body{{font-family:sans-serif;max-width:1100px;margin:2em auto;padding:0 1em;line-height:1.45}}\
             table{{border-collapse:collapse;margin:1em 0}}td,th{{border:1px solid #bbb;padding:3px 8px;text-align:left}}\
             th{{background:#eee}}img{{max-width:100%;border:1px solid #ddd}}code{{background:#f3f3f3;padding:0 3px}}\
             figcaption{{font-style:italic;color:#444}}</style>\n</head>\n<body>\n",
            html_escape(title)
        );
        for b in &self.blocks {
            match b {
                Block::Heading(l, t) => {
                    let _ = writeln!(s, "<h{l}>{}</h{l}>", html_text(t));
                }
                Block::Para(t) => {
                    let _ = writeln!(s, "<p>{}</p>", html_text(t));
                }
                Block::List(items) => {
                    s.push_str("<ul>\n");
                    for i in items {
                        let _ = writeln!(s, "<li>{}</li>", html_text(i));
                    }
                    s.push_str("</ul>\n");
                }
                Block::Table(h, rows) => {
                    s.push_str("<table>\n<tr>");
                    for c in h {
                        let _ = write!(s, "<th>{}</th>", html_text(c));
                    }
                    s.push_str("</tr>\n");
                    for r in rows {
                        s.push_str("<tr>");
                        for c in r {
                            let _ = write!(s, "<td>{}</td>", html_text(c));
                        }
                        s.push_str("</tr>\n");
                    }
                    s.push_str("</table>\n");
                }
                Block::Image(f, cap) => match image(f) {
                    Some(src) => {
                        let _ = writeln!(
                            s,
                            "<figure><img src=\"{}\" alt=\"{}\"><figcaption>{}</figcaption></figure>",
                            html_escape(&src),
                            html_escape(cap),
                            html_text(cap)
                        );
                    }
                    None => {
                        let _ =
                            writeln!(s, "<p>[image {}: {}]</p>", html_escape(f), html_text(cap));
                    }
                },
            }
        }
        s.push_str("</body>\n</html>\n");
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn same_content_in_both_forms() {
        let mut d = Document::default();
        d.push(Block::Heading(1, "Sample <a>".into()));
        d.push(Block::Para("width `hwhm_deg` 6 & more".into()));
        d.push(Block::Table(vec!["a|b".into()], vec![vec!["1".into()]]));
        d.push(Block::Image("x.png".into(), "the map".into()));
        let md = d.to_markdown();
        assert!(
            md.contains("# Sample <a>") && md.contains("a\\|b") && md.contains("![the map](x.png)")
        );
        let html = d.to_html("t", &|f| {
            (f == "x.png").then(|| "data:image/png;base64,AAAA".into())
        });
        assert!(html.contains("<h1>Sample &lt;a&gt;</h1>"));
        assert!(html.contains("<code>hwhm_deg</code> 6 &amp; more"));
        assert!(html.contains("src=\"data:image/png;base64,AAAA\""));
        assert!(!html.contains("http"));
        assert_eq!(d.images(), vec!["x.png"]);
    }
}
