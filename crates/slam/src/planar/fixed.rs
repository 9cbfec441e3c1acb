//! Landmarks the filter no longer estimates (frozen, or an anchor), with their ids:
//! the one list the point map and the wall map each keep of theirs.

/// Items in the order they left the filter (`k` in `Target::Fixed(k)` and
/// `Target::FixedWall(k)`), each with its landmark id.
#[derive(Debug, Clone)]
pub(super) struct Fixed<T> {
    items: Vec<T>,
    ids: Vec<u64>,
}

impl<T> Default for Fixed<T> {
    fn default() -> Self {
        Self {
            items: Vec::new(),
            ids: Vec::new(),
        }
    }
}

impl<T> Fixed<T> {
    /// Landmark `id` leaves the filter, known from now on as `item`.
    pub fn push(&mut self, id: u64, item: T) {
        self.items.push(item);
        self.ids.push(id);
    }

    /// The items, in the order fixed.
    pub fn items(&self) -> &[T] {
        &self.items
    }

    /// The id of the `k`-th item.
    pub fn id(&self, k: usize) -> u64 {
        self.ids[k]
    }

    /// The position of landmark `id` in the list, if it is in it.
    pub fn index_of(&self, id: u64) -> Option<usize> {
        self.ids.iter().position(|&f| f == id)
    }

    /// Landmark `id`'s item, if it is in the list.
    pub fn get(&self, id: u64) -> Option<&T> {
        self.index_of(id).map(|k| &self.items[k])
    }

    /// Every item with its id, in the order fixed.
    pub fn iter(&self) -> impl Iterator<Item = (u64, &T)> {
        self.ids.iter().copied().zip(&self.items)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn items_keep_their_ids_and_order() {
        let mut fixed = Fixed::default();
        fixed.push(7, "a");
        fixed.push(3, "b");
        assert_eq!(fixed.items(), ["a", "b"]);
        assert_eq!((fixed.id(0), fixed.id(1)), (7, 3));
        assert_eq!((fixed.index_of(3), fixed.index_of(5)), (Some(1), None));
        assert_eq!((fixed.get(7), fixed.get(5)), (Some(&"a"), None));
        assert_eq!(fixed.iter().collect::<Vec<_>>(), [(7, &"a"), (3, &"b")]);
    }
}
