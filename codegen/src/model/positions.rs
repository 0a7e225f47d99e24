//! Source positions of every key and value of a YAML document, by key path.
//!
//! serde tells us *which* value is wrong (its key path); this index tells us *where* it is.
//! It is built from the event stream of `yaml-rust2`, which carries a marker per event.

use rustc_hash::FxHashMap as HashMap;

use yaml_rust2::parser::{Event, MarkedEventReceiver, Parser};
use yaml_rust2::scanner::Marker;

/// One step of a key path.
#[derive(Clone, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Segment {
    /// A mapping key.
    Key(String),
    /// A sequence index.
    Index(usize),
}

/// A key path from the document root.
pub type KeyPath = Vec<Segment>;

/// Renders a key path as `bodies[2].mass`.
pub fn display_path(path: &[Segment]) -> String {
    let mut out = String::new();
    for segment in path {
        match segment {
            Segment::Key(k) => {
                if !out.is_empty() {
                    out.push('.');
                }
                out.push_str(k);
            }
            Segment::Index(i) => out.push_str(&format!("[{i}]")),
        }
    }
    out
}

/// Line and column (both 1-based).
pub type Position = (usize, usize);

/// Positions of values and of keys, by path.
#[derive(Debug)]
pub struct PositionIndex {
    /// The tree of the document's paths: node 0 is the empty path, every other node a child of
    /// its parent by one segment (`children`). A node's value position and, for a mapping
    /// entry, its key's; `None` for a node only on the way to others (inside a complex key).
    /// A tree, not a map from whole paths: a node costs one segment, not a copy of its path
    /// (the index is built for every model rejected after parsing).
    nodes: Vec<Option<(Position, Option<Position>)>>,
    children: HashMap<(usize, Segment), usize>,
    /// The first key that repeats a key of the same mapping, and where the repetition is.
    duplicate: Option<(KeyPath, Position)>,
}

impl Default for PositionIndex {
    fn default() -> Self {
        PositionIndex { nodes: vec![None], children: HashMap::default(), duplicate: None }
    }
}

impl PositionIndex {
    /// Indexes `text`; a document the event parser cannot read gives an empty index (the
    /// serde parser reports the syntax error itself).
    pub fn build(text: &str) -> Self {
        let mut builder = Builder { ids: vec![0], ..Builder::default() };
        let mut parser = Parser::new_from_str(text);
        if parser.load(&mut builder, false).is_err() {
            return builder.index;
        }
        builder.index
    }

    /// The node of `path`, if the tree has it.
    fn node(&self, path: &[Segment]) -> Option<usize> {
        path.iter().try_fold(0, |id, segment| self.children.get(&(id, segment.clone())).copied())
    }

    /// The position of the value at `path`, or of its nearest indexed ancestor.
    pub fn value(&self, path: &[Segment]) -> Position {
        // Every prefix of a node is a node: the nearest indexed ancestor is the deepest node
        // with a position on the way down.
        let mut id = 0;
        let mut found = self.nodes[0].map(|(p, _)| p);
        for segment in path {
            let Some(&child) = self.children.get(&(id, segment.clone())) else { break };
            id = child;
            if let Some((p, _)) = self.nodes[id] {
                found = Some(p);
            }
        }
        found.unwrap_or((1, 1))
    }

    /// The position of the key that introduces `path` (falls back to the value).
    pub fn key(&self, path: &[Segment]) -> Position {
        self.node(path)
            .and_then(|id| self.nodes[id])
            .and_then(|(_, key)| key)
            .unwrap_or_else(|| self.value(path))
    }

    /// The first repeated key of a mapping (its path and the position of the repetition).
    pub fn duplicate_key(&self) -> Option<(&[Segment], Position)> {
        self.duplicate.as_ref().map(|(path, pos)| (path.as_slice(), *pos))
    }

    /// `true` if the path is indexed.
    pub fn contains(&self, path: &[Segment]) -> bool {
        self.node(path).is_some_and(|id| self.nodes[id].is_some())
    }
}

/// A collection being read; `unplaced` until its first entry is seen.
enum Frame {
    Mapping { pending_key: Option<(String, Position)>, unplaced: bool },
    Sequence { next: usize, unplaced: bool },
}

#[derive(Default)]
struct Builder {
    index: PositionIndex,
    stack: Vec<Frame>,
    path: KeyPath,
    /// The node of each prefix of `path` (`ids[k]` for `path[..k]`; `ids[0]` is the root).
    ids: Vec<usize>,
}

impl Builder {
    /// The node of `path`.
    fn current(&self) -> usize {
        self.ids.last().copied().unwrap_or(0)
    }

    /// Descends to the child `segment` of the current node (made if new).
    fn push(&mut self, segment: Segment) -> usize {
        let parent = self.current();
        let next = self.index.nodes.len();
        let id = *self.index.children.entry((parent, segment.clone())).or_insert(next);
        if id == next {
            self.index.nodes.push(None);
        }
        self.path.push(segment);
        self.ids.push(id);
        id
    }

    /// Called when a node (scalar or collection start) begins at `pos`. Returns `false` if
    /// this scalar was a mapping key.
    fn begin_node(&mut self, scalar_key: Option<String>, pos: Position) -> bool {
        // yaml-rust2 marks the start of a block collection late (a block mapping at its first
        // key's `:`); the collection begins no later than its first entry.
        // `self.path` is still the collection's own here.
        if let Some(Frame::Mapping { unplaced, .. } | Frame::Sequence { unplaced, .. }) =
            self.stack.last_mut()
        {
            if std::mem::take(unplaced) {
                let id = self.current();
                if let Some((start, _)) = &mut self.index.nodes[id] {
                    *start = (*start).min(pos);
                }
            }
        }
        match self.stack.last_mut() {
            Some(Frame::Mapping { pending_key, .. }) => {
                if pending_key.is_none() {
                    // This node is a key.
                    let key = scalar_key.unwrap_or_else(|| "<complex key>".to_string());
                    *pending_key = Some((key, pos));
                    return false;
                }
                let (key, key_pos) = pending_key.take().unwrap_or_default();
                let id = self.push(Segment::Key(key));
                // A repeated key: the first repetition is reported; the later entry's
                // positions are kept.
                if self.index.nodes[id].is_some() && self.index.duplicate.is_none() {
                    self.index.duplicate = Some((self.path.clone(), key_pos));
                }
                self.index.nodes[id] = Some((pos, Some(key_pos)));
                return true;
            }
            Some(Frame::Sequence { next, .. }) => {
                let i = *next;
                *next += 1;
                self.push(Segment::Index(i));
            }
            None => {}
        }
        let id = self.current();
        self.index.nodes[id] = Some((pos, None));
        true
    }

    fn end_node(&mut self) {
        if !self.stack.is_empty() {
            self.path.pop();
            self.ids.pop();
        }
    }

    /// A scalar or an alias: a node that ends where it begins (unless it is a key).
    fn leaf(&mut self, scalar_key: Option<String>, pos: Position) {
        if self.begin_node(scalar_key, pos) {
            self.end_node();
        }
    }
}

impl MarkedEventReceiver for Builder {
    fn on_event(&mut self, event: Event, mark: Marker) {
        let pos = (mark.line(), mark.col() + 1);
        match event {
            // The scalar's text moves into the path when it is a key.
            Event::Scalar(value, ..) => self.leaf(Some(value), pos),
            Event::Alias(..) => self.leaf(None, pos),
            Event::MappingStart(..) => {
                let is_value = self.begin_node(None, pos);
                if !is_value {
                    // A complex (mapping) key: index nothing inside it.
                    self.push(Segment::Key("<complex key>".into()));
                }
                self.stack.push(Frame::Mapping { pending_key: None, unplaced: true });
            }
            Event::SequenceStart(..) => {
                let is_value = self.begin_node(None, pos);
                if !is_value {
                    self.push(Segment::Key("<complex key>".into()));
                }
                self.stack.push(Frame::Sequence { next: 0, unplaced: true });
            }
            Event::MappingEnd | Event::SequenceEnd => {
                self.stack.pop();
                self.end_node();
            }
            _ => {}
        }
    }
}

#[cfg(test)]
#[path = "positions_reference.rs"]
mod reference;

#[cfg(test)]
mod tests {
    use super::*;

    /// The tree answers as the map of whole paths it replaced, for every indexed path, paths
    /// below them that exist nowhere, and the first duplicate key.
    fn same_as_reference(text: &str) -> usize {
        let tree = PositionIndex::build(text);
        let map = reference::PositionIndex::build(text);
        assert_eq!(tree.duplicate_key(), map.duplicate_key(), "{text}");
        let mut checked = 0;
        let mut paths: Vec<KeyPath> = map.paths().cloned().collect();
        paths.sort();
        for path in paths {
            let mut deeper = path.clone();
            deeper.push(Segment::Key("nowhere".into()));
            let mut indexed = path.clone();
            indexed.push(Segment::Index(7));
            let mut shorter = path.clone();
            shorter.pop();
            for p in [&path, &deeper, &indexed, &shorter] {
                assert_eq!(tree.value(p), map.value(p), "value {p:?} in\n{text}");
                assert_eq!(tree.key(p), map.key(p), "key {p:?} in\n{text}");
                assert_eq!(tree.contains(p), map.contains(p), "contains {p:?} in\n{text}");
                checked += 1;
            }
        }
        let unknown = [Segment::Key("nowhere".into())];
        assert_eq!(tree.value(&unknown), map.value(&unknown));
        assert_eq!(tree.value(&[]), map.value(&[]));
        checked
    }

    #[test]
    fn the_path_tree_answers_as_the_map_of_paths() {
        let workspace = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
        let mut texts: Vec<String> = Vec::new();
        for dir in [
            "models",
            "codegen/tests/bad-models",
            "codegen/tests/good-models",
            "codegen/tests/closed-chains",
            "tests/ui/models",
            "fuzz/corpus",
            "fuzz/findings",
        ] {
            for entry in std::fs::read_dir(workspace.join(dir)).unwrap().flatten() {
                if let Ok(text) = std::fs::read_to_string(entry.path()) {
                    // The whole file and cuts of it (documents that end early or mid-token).
                    for cut in 1..=8 {
                        let at = text.len() * cut / 8;
                        if text.is_char_boundary(at) {
                            texts.push(text[..at].to_string());
                        }
                    }
                }
            }
        }
        // Shapes the model files do not have: duplicates (of keys serde_yaml tells apart too),
        // complex keys, aliases, nested sequences, a scalar document, flow collections.
        for text in [
            "a: 1\na: 2\nb: {c: 3, c: 4}\n",
            "1: x\n\"1\": y\nk:\n  - [1, 2]\n  - {p: q}\n",
            "? {x: 1}\n: v\n? [a, b]\n: w\n? {x: 1}\n: z\n",
            "a: &r {x: [1, 2]}\nb: *r\n*r : 3\n",
            "- - - 1\n  - 2\n- {a: [b, {c: d}]}\n",
            "just a scalar\n",
            "",
            "k: [1, {a: 1, a: 2}, [x, x]]\nk: {a: 3}\n",
            "x:\n  y:\n    z: 1\n  y:\n    w: 2\n",
        ] {
            texts.push(text.to_string());
        }
        let checked: usize = texts.iter().map(|t| same_as_reference(t)).sum();
        assert!(checked > 10_000, "{checked} lookups in {} documents", texts.len());
    }
}
