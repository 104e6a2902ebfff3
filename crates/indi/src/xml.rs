//! INDI's XML stream: the elements indiserver sends, read one top-level element at a time,
//! and the elements the driver writes, escaped by quick-xml.

use quick_xml::events::{BytesStart, BytesText, Event};
use quick_xml::{Reader, Writer};
use std::io::BufRead;

/// One element with its attributes, text and children.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Node {
    pub name: String,
    pub attrs: Vec<(String, String)>,
    pub text: String,
    pub children: Vec<Node>,
}

impl Node {
    pub fn attr(&self, key: &str) -> Option<&str> {
        self.attrs
            .iter()
            .find(|(k, _)| k == key)
            .map(|(_, v)| v.as_str())
    }
}

#[derive(Debug, thiserror::Error)]
#[error("INDI XML from the server: {0}")]
pub struct XmlError(String);

/// Reads the server's stream: a sequence of top-level elements with no root.
pub struct Incoming<R: BufRead> {
    reader: Reader<R>,
    buf: Vec<u8>,
}

impl<R: BufRead> Incoming<R> {
    pub fn new(r: R) -> Incoming<R> {
        let mut reader = Reader::from_reader(r);
        reader.config_mut().trim_text(true);
        Incoming {
            reader,
            buf: Vec::new(),
        }
    }

    /// The next complete top-level element; `None` when the stream ends.
    pub fn next_node(&mut self) -> Result<Option<Node>, XmlError> {
        let mut stack: Vec<Node> = Vec::new();
        loop {
            self.buf.clear();
            let ev = self
                .reader
                .read_event_into(&mut self.buf)
                .map_err(|e| XmlError(e.to_string()))?;
            let done = match ev {
                Event::Start(e) => {
                    stack.push(open(&e)?);
                    None
                }
                Event::Empty(e) => Some(open(&e)?),
                Event::Text(t) => {
                    if let Some(top) = stack.last_mut() {
                        top.text
                            .push_str(&t.unescape().map_err(|e| XmlError(e.to_string()))?);
                    }
                    None
                }
                Event::End(_) => stack.pop(),
                Event::Eof => return Ok(None),
                _ => None,
            };
            if let Some(node) = done {
                match stack.last_mut() {
                    Some(parent) => parent.children.push(node),
                    None => return Ok(Some(node)),
                }
            }
        }
    }
}

fn open(e: &BytesStart) -> Result<Node, XmlError> {
    let name = String::from_utf8_lossy(e.name().as_ref()).into_owned();
    let mut attrs = Vec::new();
    for a in e.attributes() {
        let a = a.map_err(|e| XmlError(e.to_string()))?;
        let v = a.unescape_value().map_err(|e| XmlError(e.to_string()))?;
        attrs.push((
            String::from_utf8_lossy(a.key.as_ref()).into_owned(),
            v.into_owned(),
        ));
    }
    Ok(Node {
        name,
        attrs,
        ..Node::default()
    })
}

/// An element to write: a name, attributes, and text or children.
#[derive(Clone, Debug, Default)]
pub struct Out {
    pub name: &'static str,
    pub attrs: Vec<(&'static str, String)>,
    pub text: Option<String>,
    pub children: Vec<Out>,
}

impl Out {
    pub fn new(name: &'static str) -> Out {
        Out {
            name,
            ..Out::default()
        }
    }
    pub fn attr(mut self, k: &'static str, v: impl Into<String>) -> Out {
        self.attrs.push((k, v.into()));
        self
    }
    pub fn text(mut self, t: impl Into<String>) -> Out {
        self.text = Some(t.into());
        self
    }
    pub fn child(mut self, c: Out) -> Out {
        self.children.push(c);
        self
    }

    /// The element as bytes, attribute values and text escaped.
    pub fn to_bytes(&self) -> Vec<u8> {
        let mut w = Writer::new(Vec::new());
        // Writing into a Vec cannot fail.
        let _ = self.write(&mut w);
        let mut v = w.into_inner();
        v.push(b'\n');
        v
    }

    fn write(&self, w: &mut Writer<Vec<u8>>) -> std::io::Result<()> {
        let el = w
            .create_element(self.name)
            .with_attributes(self.attrs.iter().map(|(k, v)| (*k, v.as_str())));
        match (&self.text, self.children.is_empty()) {
            (Some(t), _) => el.write_text_content(BytesText::new(t)).map(|_| ()),
            (None, true) => el.write_empty().map(|_| ()),
            (None, false) => el
                .write_inner_content(|w| {
                    for c in &self.children {
                        c.write(w)?;
                    }
                    Ok(())
                })
                .map(|_| ()),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_stream_of_elements_reads_one_at_a_time() {
        let s = "<getProperties version='1.7'/>\n<newNumberVector device='F &amp; co' name='ABS'>\
                 <oneNumber name='X'>\n 12.5\n</oneNumber></newNumberVector>";
        let mut r = Incoming::new(s.as_bytes());
        let a = r.next_node().unwrap().unwrap();
        assert_eq!(
            (a.name.as_str(), a.attr("version")),
            ("getProperties", Some("1.7"))
        );
        let b = r.next_node().unwrap().unwrap();
        assert_eq!(b.attr("device"), Some("F & co"));
        assert_eq!(b.children[0].text, "12.5");
        assert_eq!(r.next_node().unwrap(), None);
    }

    #[test]
    fn written_text_and_attributes_are_escaped() {
        let o = Out::new("oneText").attr("name", "a\"<").text("x & y");
        let s = String::from_utf8(o.to_bytes()).unwrap();
        assert_eq!(s, "<oneText name=\"a&quot;&lt;\">x &amp; y</oneText>\n");
    }
}
