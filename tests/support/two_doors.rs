//! The two-door room shared by the route-choice suites.

/// A room 16 x 8 m with a door 1 m wide near each end of its lower wall (exit 0 on the left at
/// x 2 to 3 m, exit 1 on the right at x 14 to 15 m) and a field over it of `metric` with the
/// `[field]` lines `field_extra`; `count` pedestrians spread over the rectangle `spawn` steer
/// by the behaviours `steering`.
pub fn two_doors(
    metric: &str,
    field_extra: &str,
    count: usize,
    spawn: ([f32; 2], [f32; 2]),
    steering: &str,
) -> String {
    let ([x0, y0], [x1, y1]) = spawn;
    format!(
        r#"
name = "two doors"
seed = 4
dt = 0.01
[geometry]
walkable = "POLYGON ((0 1, 2 1, 2 0, 3 0, 3 1, 14 1, 14 0, 15 0, 15 1, 16 1, 16 9, 0 9, 0 1))"
[field]
cell_size = 0.25
clearance = 0.2
metric = "{metric}"
{field_extra}
[[exits]]
min = [2, 0]
max = [3, 0.5]
[[exits]]
min = [14, 0]
max = [15, 0.5]
[[groups]]
count = {count}
spawn = {{ kind = "spread", min = [{x0}, {y0}], max = [{x1}, {y1}], distance = 0.42 }}
model = "kinematic"
max_speed = 2.5
radius = 0.2
steering = {{ behaviours = [{steering}] }}
pedestrian = {{}}
"#
    )
}
