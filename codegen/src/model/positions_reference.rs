//! The position index as it was before the path tree (a map from every node's whole key
//! path), kept for the test that the tree gives the same answers.

use rustc_hash::FxHashMap as HashMap;

use yaml_rust2::parser::{Event, MarkedEventReceiver, Parser};
use yaml_rust2::scanner::Marker;

use super::{KeyPath, Position, Segment};

/// Positions of values and of keys, by path.
#[derive(Debug, Default)]
pub struct PositionIndex {
    /// Each node's value position and, for a mapping entry, its key's (one map, so that a
    /// node costs one path and one insertion: the index is built for every model loaded).
    nodes: HashMap<KeyPath, (Position, Option<Position>)>,
    /// The first key that repeats a key of the same mapping, and where the repetition is.
    duplicate: Option<(KeyPath, Position)>,
}

impl PositionIndex {
    /// Indexes `text`; a document the event parser cannot read gives an empty index (the
    /// serde parser reports the syntax error itself).
    pub fn build(text: &str) -> Self {
        let mut builder = Builder::default();
        let mut parser = Parser::new_from_str(text);
        if parser.load(&mut builder, false).is_err() {
            return builder.index;
        }
        builder.index
    }

    /// The position of the value at `path`, or of its nearest indexed ancestor.
    pub fn value(&self, path: &[Segment]) -> Position {
        for len in (0..=path.len()).rev() {
            if let Some((p, _)) = self.nodes.get(&path[..len]) {
                return *p;
            }
        }
        (1, 1)
    }

    /// The position of the key that introduces `path` (falls back to the value).
    pub fn key(&self, path: &[Segment]) -> Position {
        self.nodes.get(path).and_then(|(_, key)| *key).unwrap_or_else(|| self.value(path))
    }

    /// The first repeated key of a mapping (its path and the position of the repetition).
    pub fn duplicate_key(&self) -> Option<(&[Segment], Position)> {
        self.duplicate.as_ref().map(|(path, pos)| (path.as_slice(), *pos))
    }

    /// `true` if the path is indexed.
    pub fn contains(&self, path: &[Segment]) -> bool {
        self.nodes.contains_key(path)
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
}

impl Builder {
    /// Called when a node (scalar or collection start) begins at `pos`. Returns `false` if
    /// this scalar was a mapping key.
    fn begin_node(&mut self, scalar_key: Option<&str>, pos: Position) -> bool {
        // yaml-rust2 marks the start of a block collection late (a block mapping at its first
        // key's `:`); the collection begins no later than its first entry.
        // `self.path` is still the collection's own here.
        if let Some(Frame::Mapping { unplaced, .. } | Frame::Sequence { unplaced, .. }) =
            self.stack.last_mut()
        {
            if std::mem::take(unplaced) {
                if let Some((start, _)) = self.index.nodes.get_mut(&self.path) {
                    *start = (*start).min(pos);
                }
            }
        }
        match self.stack.last_mut() {
            Some(Frame::Mapping { pending_key, .. }) => {
                if pending_key.is_none() {
                    // This node is a key.
                    let key = scalar_key.unwrap_or("<complex key>").to_string();
                    *pending_key = Some((key, pos));
                    return false;
                }
                let (key, key_pos) = pending_key.take().unwrap_or_default();
                self.path.push(Segment::Key(key));
                match self.index.nodes.get_mut(&self.path) {
                    // A repeated key: the first repetition is reported; the later entry's
                    // positions are kept.
                    Some(entry) => {
                        *entry = (pos, Some(key_pos));
                        if self.index.duplicate.is_none() {
                            self.index.duplicate = Some((self.path.clone(), key_pos));
                        }
                    }
                    None => {
                        self.index.nodes.insert(self.path.clone(), (pos, Some(key_pos)));
                    }
                }
                return true;
            }
            Some(Frame::Sequence { next, .. }) => {
                let i = *next;
                *next += 1;
                self.path.push(Segment::Index(i));
            }
            None => {}
        }
        self.index.nodes.insert(self.path.clone(), (pos, None));
        true
    }

    fn end_node(&mut self) {
        if !self.stack.is_empty() {
            self.path.pop();
        }
    }
}

impl MarkedEventReceiver for Builder {
    fn on_event(&mut self, event: Event, mark: Marker) {
        let pos = (mark.line(), mark.col() + 1);
        match event {
            Event::Scalar(value, ..) if self.begin_node(Some(&value), pos) => self.end_node(),
            Event::Alias(..) if self.begin_node(None, pos) => self.end_node(),
            Event::MappingStart(..) => {
                let is_value = self.begin_node(None, pos);
                if !is_value {
                    // A complex (mapping) key: index nothing inside it.
                    self.path.push(Segment::Key("<complex key>".into()));
                }
                self.stack.push(Frame::Mapping { pending_key: None, unplaced: true });
            }
            Event::SequenceStart(..) => {
                let is_value = self.begin_node(None, pos);
                if !is_value {
                    self.path.push(Segment::Key("<complex key>".into()));
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

impl PositionIndex {
    /// Every indexed path.
    pub fn paths(&self) -> impl Iterator<Item = &KeyPath> {
        self.nodes.keys()
    }
}
