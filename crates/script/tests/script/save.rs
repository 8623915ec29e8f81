//! Saving tuned values into species and scene files (`shoal_script::edit`): only the edited
//! literals change; each test compares the whole file before and after.

use std::path::Path;

use shoal_script::edit::{self, Edit, EditError, EditOptions, KeyPath, LuaValue};

use crate::common::{repo, scratch_repo};

fn edits(args: &[&str]) -> Vec<Edit> {
    args.iter().map(|a| Edit::parse(a).unwrap()).collect()
}

fn shipped(rel: &str) -> String {
    std::fs::read_to_string(repo().join(rel)).unwrap()
}

fn set(source: &str, args: &[&str]) -> Result<String, EditError> {
    edit::edit_source(source, "f.lua", &edits(args), EditOptions::default())
}

#[test]
fn test_a_number_changes_and_nothing_else() {
    let before = shipped("scripts/species/barracuda.lua");
    let after = set(&before, &["motion.s=75", "max_speed=180.5"]).unwrap();
    let want = before
        .replacen("    s = 70,  ", "    s = 75,  ", 1)
        .replacen("max_speed = 170,", "max_speed = 180.5,", 1);
    assert_ne!(
        want, before,
        "the expected text differs from the shipped one"
    );
    assert_eq!(after, want);
}

#[test]
fn test_a_missing_table_is_inserted_in_the_files_indentation() {
    let before = shipped("scripts/species/black_porgy.lua");
    let after = set(&before, &["motion.s=70"]).unwrap();
    let line = "  decision_hz = 10,        -- behaviour decisions per second (staggered over the 60 Hz tick)\n";
    assert!(
        before.contains(line),
        "the shipped file changed: update this test"
    );
    let want = before.replacen(line, &format!("{line}  motion = {{ s = 70 }},\n"), 1);
    assert_eq!(after, want);
    // A second key goes into the table the first one made, on the same line.
    let again = set(&after, &["motion.l=60"]).unwrap();
    assert_eq!(again, want.replacen("{ s = 70 }", "{ s = 70, l = 60 }", 1));
}

#[test]
fn test_an_expression_is_replaced_only_when_asked_and_kept_in_a_comment() {
    let before = shipped("scripts/species/barracuda.lua");
    let err = set(&before, &["motion.max_amp=14"]).unwrap_err();
    let msg = err.to_string();
    assert!(msg.contains("f.lua:13:"), "{msg}");
    assert!(
        msg.contains("80 * 0.16") && msg.contains("--replace-expressions"),
        "{msg}"
    );
    let opts = EditOptions {
        replace_expressions: true,
    };
    let after = edit::edit_source(&before, "f.lua", &edits(&["motion.max_amp=14"]), opts).unwrap();
    assert_eq!(
        after,
        before.replacen(
            "max_amp = 80 * 0.16,",
            "max_amp = 14 --[[was: 80 * 0.16]],",
            1
        )
    );
}

#[test]
fn test_lists_are_edited_item_by_item_and_comments_stay() {
    let before = shipped("scripts/scenes/default.lua");
    let after = set(
        &before,
        &["obstacles[1].pos={260, 60, -100}", "currents[1].radius=175"],
    )
    .unwrap();
    let want = before
        .replacen(
            "{ pos = { 250, 60, -120 }, radius = 60 }",
            "{ pos = { 260, 60, -100 }, radius = 60 }",
            1,
        )
        .replacen(
            "{ pos = { 0, 200, 0 }, radius = 150,",
            "{ pos = { 0, 200, 0 }, radius = 175,",
            1,
        );
    assert_eq!(after, want);
    assert!(after.contains("-- units/s: about half a minute from the surface to the floor"));
}

#[test]
fn test_one_line_tables_lists_and_files_without_trailing_commas() {
    let src = "-- c\nreturn {\n  tank = { min = {0, 0, 0} },\n  obstacles = {\n    { pos = {1, 2, 3}, radius = 4 }\n  }\n}\n";
    let after = set(
        src,
        &[
            "tank.max={9, 9, 9}",
            "obstacles[2]={ pos = {5, 6, 7}, radius = 8 }",
            "food_lifetime=30",
        ],
    )
    .unwrap();
    assert_eq!(
        after,
        "-- c\nreturn {\n  tank = { min = {0, 0, 0}, max = { 9, 9, 9 } },\n  obstacles = {\n    { pos = {1, 2, 3}, radius = 4 },\n    { pos = {5, 6, 7}, radius = 8 }\n  },\n  food_lifetime = 30\n}\n"
    );
    // (The file writes no comma after a table's last item; neither do the inserted lines.)
    // Setting a value to what is written changes nothing.
    assert_eq!(set(&after, &["tank.max[2]=9"]).unwrap(), after);
}

#[test]
fn test_what_cannot_be_edited_is_refused_naming_key_and_line() {
    let cases: &[(&str, &str, &str)] = &[
        (
            "return { s = 1, s = 2 }\n",
            "s=3",
            "f.lua:1: cannot edit s losslessly: it is set more than once",
        ),
        (
            "local t = { motion = {} }\nt.motion = { s = 1 }\nreturn t\n",
            "motion.s=2",
            "f.lua:2: cannot edit motion.s losslessly: line 2 assigns into `t`",
        ),
        (
            "return make()\n",
            "s=2",
            "f.lua:1: cannot edit the file losslessly: it returns `make()`",
        ),
        (
            "local b = {}\nreturn {\n  motion = b,\n}\n",
            "motion.s=2",
            "f.lua:3: cannot edit motion.s losslessly: motion is `b`, not a table literal",
        ),
        ("return {\n  x = = 1,\n}\n", "x=2", "f.lua:2:"),
        (
            "return { list = { 1 } }\n",
            "list[3]=2",
            "the list has 1 item(s); a new one goes at [2], not [3]",
        ),
        (
            "return { motion = { s = 1 } }\n",
            "motion.s=\"fast\"",
            "f.lua:1: motion.s is a number in the file; refusing `\"fast\"` (a string)",
        ),
        (
            "return { predator = true }\n",
            "predator=1",
            "predator is true or false in the file",
        ),
    ];
    for (src, arg, want) in cases {
        let msg = set(src, &[arg]).unwrap_err().to_string();
        assert!(
            msg.starts_with(want) || msg.contains(want),
            "{arg} on {src:?}: {msg}"
        );
    }
}

#[test]
fn test_keys_and_values_as_typed() {
    assert_eq!(
        KeyPath::parse("fish[2].params.speed").unwrap().to_string(),
        "fish[2].params.speed"
    );
    for bad in ["", "motion..s", "fish[0]", "fish[x]", "2fast", "motion.s["] {
        assert!(KeyPath::parse(bad).is_err(), "{bad:?} parsed");
    }
    assert_eq!(
        LuaValue::parse("school").unwrap(),
        LuaValue::Str("\"school\"".into())
    );
    assert_eq!(
        LuaValue::parse("-120").unwrap(),
        LuaValue::Number("-120".into())
    );
    assert_eq!(LuaValue::from_f32(0.1).text(), "0.1");
    assert!(LuaValue::parse("os.exit()").is_err());
    assert!(
        Edit::parse("motion.s")
            .unwrap_err()
            .to_string()
            .contains("KEY.PATH=VALUE")
    );
}

fn save(path: &Path, args: &[&str]) -> Result<edit::Saved, EditError> {
    edit::save(path, &edits(args), EditOptions::default())
}

#[test]
fn test_save_checks_the_result_as_the_simulation_reads_it() {
    let (_dir, root) = scratch_repo();
    let porgy = root.join("scripts/species/black_porgy.lua");
    let before = std::fs::read_to_string(&porgy).unwrap();
    // Unknown keys get the loader's "did you mean"; nothing is written.
    let msg = save(&porgy, &["motion.lamda=60"]).unwrap_err().to_string();
    assert!(
        msg.contains("did you mean \"lambda\"?") && msg.contains("nothing was written"),
        "{msg}"
    );
    let msg = save(&porgy, &["motion.s=\"fast\""])
        .unwrap_err()
        .to_string();
    assert!(
        msg.contains("black_porgy.lua") && msg.contains("motion.s"),
        "{msg}"
    );
    let msg = save(&porgy, &["decision_hz=600"]).unwrap_err().to_string();
    assert!(
        msg.contains("decision_hz must be a number in (0, 60]"),
        "{msg}"
    );
    assert_eq!(std::fs::read_to_string(&porgy).unwrap(), before);
    // A good edit is written, and a second identical one changes nothing.
    assert!(save(&porgy, &["motion.s=70"]).unwrap().changed);
    assert!(!save(&porgy, &["motion.s=70"]).unwrap().changed);
    let scene = root.join("scripts/scenes/default.lua");
    let msg = save(&scene, &["fish[1].species=\"black_porgie\""])
        .unwrap_err()
        .to_string();
    assert!(msg.contains("did you mean \"black_porgy\"?"), "{msg}");
    let msg = save(&scene, &["obstacles[1].radius=-5"])
        .unwrap_err()
        .to_string();
    assert!(msg.contains("obstacles[1].radius"), "{msg}");
    let msg = save(&scene, &["obstacle[1].radius=5"])
        .unwrap_err()
        .to_string();
    assert!(msg.contains("did you mean \"obstacles\"?"), "{msg}");
    let other = root.join("scripts/behaviors/school.lua");
    assert!(matches!(
        save(&other, &["x=1"]),
        Err(EditError::UnknownKind(_))
    ));
}

#[test]
fn test_nil_removes_a_key_or_list_item_with_its_line() {
    let before = shipped("scripts/scenes/default.lua");
    let rock = "    { pos = { 250, 60, -120 }, radius = 60 },\n";
    assert!(
        before.contains(rock),
        "the shipped scene changed: update this test"
    );
    // A list item on a line of its own goes with its line; the next one moves up.
    let after = set(&before, &["obstacles[1]=nil"]).unwrap();
    assert_eq!(after, before.replacen(rock, "", 1));
    // A key, its trailing comment with it.
    let after = set(&before, &["food_lifetime=nil"]).unwrap();
    assert_eq!(
        after,
        before.replacen(
            "  food_lifetime = 90,     -- seconds before an uneaten pellet dissolves\n",
            "",
            1
        )
    );
    // Items of a one-line list: the separator goes too, first, middle or last.
    let one = "return {\n  food = { {1, 2, 3}, {4, 5, 6}, {7, 8, 9} },\n}\n";
    for (k, want) in [
        (1, "{ {4, 5, 6}, {7, 8, 9} }"),
        (2, "{ {1, 2, 3}, {7, 8, 9} }"),
        (3, "{ {1, 2, 3}, {4, 5, 6} }"),
    ] {
        let after = set(one, &[&format!("food[{k}]=nil")]).unwrap();
        assert_eq!(
            after,
            one.replacen("{ {1, 2, 3}, {4, 5, 6}, {7, 8, 9} }", want, 1),
            "food[{k}]"
        );
    }
    // A key that is not there: nothing to remove.
    assert_eq!(set(&before, &["food_sink_speed_typo=nil"]).unwrap(), before);
    assert_eq!(LuaValue::parse("nil").unwrap(), LuaValue::Nil);
}
