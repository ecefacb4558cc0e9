//! Small helpers over roxmltree: namespace-free element lookup, checked
//! number lists and `#url` resolution, each failing with a located error.

use std::borrow::Cow;
use std::cell::RefCell;
use std::collections::HashMap;

use glam::Vec3;
use roxmltree::Node;

use super::error::{LoadError, Source};

/// First child element with local name `name`.
pub fn child<'a, 'i>(node: Node<'a, 'i>, name: &str) -> Option<Node<'a, 'i>> {
    node.children()
        .find(|c| c.is_element() && c.tag_name().name() == name)
}

/// All child elements with local name `name`.
pub fn children<'a, 'i: 'a>(
    node: Node<'a, 'i>,
    name: &'a str,
) -> impl Iterator<Item = Node<'a, 'i>> + 'a {
    node.children()
        .filter(move |c| c.is_element() && c.tag_name().name() == name)
}

/// First child element, whatever its name.
pub fn first_element<'a, 'i>(node: Node<'a, 'i>) -> Option<Node<'a, 'i>> {
    node.children().find(|c| c.is_element())
}

/// The character data of `node`: its text pieces joined. roxmltree's
/// `text()` is the first piece only, so a comment inside a number list
/// (`<p>0 1 2 <!-- quad --> 3</p>`) would cut the list off silently.
pub fn text<'a>(node: Node<'a, '_>) -> Cow<'a, str> {
    let mut pieces = node
        .children()
        .filter_map(|c| c.is_text().then(|| c.text()).flatten());
    let first = pieces.next().unwrap_or("");
    match pieces.next() {
        None => Cow::Borrowed(first),
        Some(second) => Cow::Owned([first, second].into_iter().chain(pieces).collect()),
    }
}

/// Follows a path of child names.
pub fn path<'a, 'i>(node: Node<'a, 'i>, names: &[&str]) -> Option<Node<'a, 'i>> {
    names.iter().try_fold(node, |n, name| child(n, name))
}

/// The innermost element still open at the end of `text` (local name and the
/// byte offset of its start tag): what a truncated file was cut off inside.
///
/// A light scan of the tags, for error messages only; markup cut off midway
/// ends the scan.
pub fn innermost_open_element(text: &str) -> Option<(&str, usize)> {
    let mut open: Vec<(&str, usize)> = Vec::new();
    let mut at = 0;
    while let Some(i) = text[at..].find('<') {
        let start = at + i;
        let tail = &text[start..];
        let skip_to = |end: &str| tail.find(end).map(|e| start + e + end.len());
        let next = if tail.starts_with("<!--") {
            skip_to("-->")
        } else if tail.starts_with("<![CDATA[") {
            skip_to("]]>")
        } else if tail.starts_with("<?") {
            skip_to("?>")
        } else if tail.starts_with("<!") {
            skip_to(">")
        } else {
            // A tag: its '>' is the first one outside quoted attribute values.
            let mut quote = None;
            let close = tail.bytes().position(|b| match quote {
                Some(q) => {
                    if b == q {
                        quote = None;
                    }
                    false
                }
                None if b == b'"' || b == b'\'' => {
                    quote = Some(b);
                    false
                }
                None => b == b'>',
            });
            let Some(close) = close else { break };
            let (closing, name_from) = match tail.strip_prefix("</") {
                Some(_) => (true, 2),
                None => (false, 1),
            };
            let name = tail[name_from..close]
                .split(|c: char| c.is_ascii_whitespace() || c == '/')
                .next()
                .unwrap_or("");
            let name = name.rsplit(':').next().unwrap_or(name);
            if closing {
                open.pop();
            } else if !tail[..close].ends_with('/') {
                open.push((name, start));
            }
            Some(start + close + 1)
        };
        match next {
            Some(next) => at = next,
            None => break,
        }
    }
    open.last().copied()
}

impl Source<'_, '_> {
    /// The text of an element that holds numbers only (no child elements).
    fn number_text<'a>(&self, node: Node<'a, '_>) -> Result<Cow<'a, str>, LoadError> {
        match first_element(node) {
            Some(inner) => Err(self.error(
                node,
                format!(
                    "holds an element <{}> where only numbers belong",
                    inner.tag_name().name()
                ),
            )),
            None => Ok(text(node)),
        }
    }

    /// The whitespace-separated numbers of `node`'s text, all finite.
    pub fn floats(&self, node: Node) -> Result<Vec<f32>, LoadError> {
        let text = self.number_text(node)?;
        let mut out = Vec::with_capacity(text.len() / 4);
        for (i, token) in text.split_ascii_whitespace().enumerate() {
            let value: f32 = token.parse().map_err(|_| {
                self.error(node, format!("value {} is not a number: {token:?}", i + 1))
            })?;
            if !value.is_finite() {
                return Err(self.error(
                    node,
                    format!(
                        "value {} is not finite: {token:?} (NaN and infinity are rejected)",
                        i + 1
                    ),
                ));
            }
            out.push(value);
        }
        Ok(out)
    }

    /// The whitespace-separated unsigned integers of `node`'s text.
    pub fn uints(&self, node: Node) -> Result<Vec<u32>, LoadError> {
        let text = self.number_text(node)?;
        let mut out = Vec::with_capacity(text.len() / 3);
        for (i, token) in text.split_ascii_whitespace().enumerate() {
            let value: u32 = token.parse().map_err(|_| {
                self.error(
                    node,
                    format!("value {} is not a non-negative integer: {token:?}", i + 1),
                )
            })?;
            out.push(value);
        }
        Ok(out)
    }

    /// Exactly `n` numbers (more are an error too: they mean a malformed record).
    pub fn floats_n(&self, node: Node, n: usize) -> Result<Vec<f32>, LoadError> {
        let v = self.floats(node)?;
        if v.len() != n {
            return Err(self.error(node, format!("expected {n} numbers, found {}", v.len())));
        }
        Ok(v)
    }

    /// At least three numbers, as a colour or vector (a fourth, alpha, is ignored).
    pub fn vec3(&self, node: Node) -> Result<Vec3, LoadError> {
        let v = self.floats(node)?;
        if v.len() < 3 || v.len() > 4 {
            return Err(self.error(node, format!("expected 3 numbers, found {}", v.len())));
        }
        Ok(Vec3::new(v[0], v[1], v[2]))
    }

    /// A single finite number.
    pub fn scalar(&self, node: Node) -> Result<f32, LoadError> {
        Ok(self.floats_n(node, 1)?[0])
    }

    /// A non-negative integer attribute, if present.
    pub fn usize_attr(&self, node: Node, name: &str) -> Result<Option<usize>, LoadError> {
        match node.attribute(name) {
            None => Ok(None),
            Some(s) => s.trim().parse().map(Some).map_err(|_| {
                self.error(
                    node,
                    format!("attribute {name}={s:?} is not a non-negative integer"),
                )
            }),
        }
    }

    /// A required attribute.
    pub fn attr<'a>(&self, node: Node<'a, '_>, name: &str) -> Result<&'a str, LoadError> {
        node.attribute(name)
            .ok_or_else(|| self.error(node, format!("missing attribute {name}")))
    }

    /// A required child element.
    pub fn require<'a, 'i>(
        &self,
        node: Node<'a, 'i>,
        name: &str,
    ) -> Result<Node<'a, 'i>, LoadError> {
        child(node, name).ok_or_else(|| self.error(node, format!("missing <{name}>")))
    }
}

/// Every element with an `id`, for resolving `#url` references.
pub struct Ids<'a, 'i> {
    /// The last element with each id: the one a reference reaches.
    map: HashMap<&'a str, Node<'a, 'i>>,
    /// The ids more than one element has, with the number of elements.
    repeated: HashMap<&'a str, usize>,
    /// Repeated ids that a reference has reached, in the order reached.
    reached: RefCell<Vec<&'a str>>,
}

impl<'a, 'i> Ids<'a, 'i> {
    pub fn index(doc: &'a roxmltree::Document<'i>) -> Self {
        let mut map = HashMap::new();
        let mut repeated = HashMap::new();
        for n in doc.descendants().filter(|n| n.is_element()) {
            if let Some(id) = n.attribute("id")
                && map.insert(id, n).is_some()
            {
                *repeated.entry(id).or_insert(1) += 1;
            }
        }
        Ids {
            map,
            repeated,
            reached: RefCell::new(Vec::new()),
        }
    }

    pub fn get(&self, id: &str) -> Option<Node<'a, 'i>> {
        let (&key, &node) = self.map.get_key_value(id)?;
        if self.repeated.contains_key(key) && !self.reached.borrow().contains(&key) {
            self.reached.borrow_mut().push(key);
        }
        Some(node)
    }

    /// A warning for each id that several elements have and a reference
    /// used (ids nothing refers to may repeat harmlessly, as the CS184
    /// scenes' node names do).
    pub fn repeated_warnings(&self, src: &Source) -> Vec<String> {
        self.reached
            .borrow()
            .iter()
            .map(|id| {
                src.warning(
                    self.map[id],
                    format!(
                        "{} elements have the id {id:?}; references to it reach this last one",
                        self.repeated[id]
                    ),
                )
            })
            .collect()
    }

    /// Resolves the `#id` in attribute `attr` of `node`, expecting an element named `kind`.
    pub fn resolve(
        &self,
        src: &Source,
        node: Node,
        attr: &str,
        kind: &str,
    ) -> Result<Node<'a, 'i>, LoadError> {
        let url = src.attr(node, attr)?;
        let id = url.strip_prefix('#').ok_or_else(|| {
            src.error(
                node,
                format!("{attr}={url:?} is not a local reference (expected \"#id\")"),
            )
        })?;
        let target = self
            .get(id)
            .ok_or_else(|| src.error(node, format!("{attr}={url:?} refers to no element")))?;
        if target.tag_name().name() != kind {
            return Err(src.error(
                node,
                format!(
                    "{attr}={url:?} refers to a <{}>, expected a <{kind}>",
                    target.tag_name().name()
                ),
            ));
        }
        Ok(target)
    }
}

#[cfg(test)]
mod tests {
    /// The name and start offset of the element left open at the end of `text`.
    use super::innermost_open_element as open;

    #[test]
    fn the_innermost_element_still_open_is_named_with_its_start() {
        let text = "<a>\n  <b x=\"1\">\n    <c>1 2";
        assert_eq!(open(text), Some(("c", text.find("<c>").unwrap())));
        // Closed and self-closing elements are not open; the parent is.
        let text = "<a><b></b><c/><d  />\n<e/>";
        assert_eq!(open(text), Some(("a", 0)));
        // A closing tag closes the innermost open element (however spelt:
        // this is for messages, the parser has judged the nesting).
        assert_eq!(open("<a><b><c></c></b>"), Some(("a", 0)));
        assert_eq!(open("<a></a>"), None);
        assert_eq!(open(""), None);
        assert_eq!(open("no markup at all"), None);
    }

    #[test]
    fn namespaces_attributes_and_whitespace_do_not_change_the_name() {
        assert_eq!(open("<c:node id=\"n\">"), Some(("node", 0)));
        assert_eq!(open("<a\n  id=\"x\">"), Some(("a", 0)));
        assert_eq!(open("<a\tid='x'>"), Some(("a", 0)));
        // A '>' or "/>" inside a quoted attribute value ends nothing.
        let text = "<a><b t=\"x > y\" u='/>'><c";
        assert_eq!(open(text), Some(("b", 3)));
        let text = "<a><b t='\"' u=\"'/>\">";
        assert_eq!(open(text), Some(("b", 3)));
    }

    #[test]
    fn comments_cdata_declarations_and_instructions_hold_no_tags() {
        let text = "<?xml version=\"1.0\"?><!DOCTYPE x><a><!-- <b> --><![CDATA[<c>]]><?pi <d>?>";
        assert_eq!(open(text), Some(("a", text.find("<a>").unwrap())));
        let text = "<a><!-- </a> -->";
        assert_eq!(open(text), Some(("a", 0)));
        let text = "<a><![CDATA[</a>]]>";
        assert_eq!(open(text), Some(("a", 0)));
        let text = "<a><?pi </a> ?>";
        assert_eq!(open(text), Some(("a", 0)));
    }

    #[test]
    fn markup_cut_off_midway_ends_the_scan() {
        // A tag, comment, section or instruction the file ends inside: the
        // element open before it is the answer.
        for tail in [
            "<b id=\"x",
            "<b",
            "<!-- <b>",
            "<![CDATA[<b>",
            "<?pi <b>",
            "<!DOC <b",
        ] {
            let text = format!("<a>{tail}");
            assert_eq!(open(&text), Some(("a", 0)), "{text:?}");
        }
    }
}
