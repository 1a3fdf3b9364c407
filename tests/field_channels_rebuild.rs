//! Goal channels: one field per goal type, rebuilt exactly when goals or obstacles change.

use throng::Error;
use throng::field::{GoalChannels, Neighbourhood, OccupancyGrid, PotentialField};

#[test]
fn changes_mark_channels_dirty_and_rebuilds_match_fresh_fields() {
    let grid = OccupancyGrid::caves(50, 40, 0.5, 4).unwrap();
    let mut ch = GoalChannels::new(grid.clone(), 0.9, Neighbourhood::Eight).unwrap();
    assert!(ch.is_empty());
    let a = ch
        .add_channel(&throng::field::random_free_cells(&grid, 2, 1).unwrap())
        .unwrap();
    let b = ch
        .add_channel(&throng::field::random_free_cells(&grid, 1, 2).unwrap())
        .unwrap();
    assert!(ch.field(a).is_none() && ch.is_dirty(a));
    assert_eq!(ch.rebuild_dirty().unwrap(), 2);
    assert_eq!(ch.rebuild_dirty().unwrap(), 0);
    let fresh = |ch: &GoalChannels, c: usize| {
        PotentialField::bfs(ch.grid(), ch.goals(c).unwrap(), 0.9, Neighbourhood::Eight).unwrap()
    };
    assert_eq!(ch.field(a).unwrap(), &fresh(&ch, a));

    // Moving one channel's goals dirties only that channel.
    ch.randomize_goals(b, 3, 77).unwrap();
    assert!(!ch.is_dirty(a) && ch.is_dirty(b));
    assert!(ch.field(b).is_none() && ch.flow(b).is_none());
    assert_eq!(ch.rebuild_dirty().unwrap(), 1);
    assert_eq!(ch.goals(b).unwrap().len(), 3);
    assert_eq!(ch.field(b).unwrap(), &fresh(&ch, b));

    // Obstacles changed at run time dirty every channel.
    let (x, y) = (0..grid.len() as u32)
        .map(|i| (i % 50, i / 50))
        .find(|&(x, y)| {
            grid.is_free(x, y)
                && !ch.goals(a).unwrap().contains(&(x, y))
                && !ch.goals(b).unwrap().contains(&(x, y))
        })
        .unwrap();
    ch.set_blocked(x, y, true).unwrap();
    assert!(ch.is_dirty(a) && ch.is_dirty(b));
    assert_eq!(ch.rebuild_dirty().unwrap(), 2);
    assert!(!ch.field(a).unwrap().is_reachable(x, y));
    assert_eq!(ch.field(a).unwrap(), &fresh(&ch, a));
    // Setting a cell to what it already is changes nothing.
    ch.set_blocked(x, y, true).unwrap();
    assert!(!ch.is_dirty(a));
    ch.set_blocked(x, y, false).unwrap();
    assert_eq!(ch.rebuild_dirty().unwrap(), 2);
    assert!(ch.field(b).unwrap().steps(x, y).is_some());
}

#[test]
fn bad_channel_requests_are_errors() {
    let grid = OccupancyGrid::parse_ascii("G.#\n...\n", "<map>")
        .unwrap()
        .grid;
    assert!(matches!(
        GoalChannels::new(grid.clone(), 1.0, Neighbourhood::Four),
        Err(Error::OutOfRange { .. })
    ));
    let mut ch = GoalChannels::new(grid, 0.5, Neighbourhood::Four).unwrap();
    assert!(matches!(ch.add_channel(&[]), Err(Error::Invalid { .. })));
    assert!(matches!(
        ch.add_channel(&[(2, 0)]),
        Err(Error::Invalid { .. })
    ));
    let c = ch.add_channel(&[(0, 0)]).unwrap();
    assert!(matches!(
        ch.set_goals(c + 1, &[(0, 0)]),
        Err(Error::Invalid { .. })
    ));
    assert!(matches!(
        ch.set_goals(c, &[(9, 9)]),
        Err(Error::Invalid { .. })
    ));
    assert_eq!(ch.goals(c).unwrap(), &[(0, 0)]);
    assert!(matches!(
        ch.set_blocked(0, 0, true),
        Err(Error::Invalid { .. })
    ));
    assert!(matches!(
        ch.set_blocked(5, 0, true),
        Err(Error::Invalid { .. })
    ));
    assert!(matches!(
        ch.randomize_goals(c, 10, 1),
        Err(Error::Invalid { .. })
    ));
}
