//! `remove_temporary_files`, as a program's signal handler calls it before exiting: every later
//! write fails and leaves the previous file and no temporary file. (Its own test binary: it
//! stops all writes of the process.)

use calib_core::io::{remove_temporary_files, write_group_atomically};
use calib_core::write_atomically;

#[test]
fn after_the_temporary_files_are_removed_nothing_more_is_written() {
    let dir = std::env::temp_dir().join(format!("calib-core-stop-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("result.json");
    write_atomically(&path, b"previous").unwrap();
    assert_eq!(remove_temporary_files(), 0);
    let err = write_atomically(&path, b"new").unwrap_err();
    assert_eq!(err.kind(), std::io::ErrorKind::Interrupted, "{err}");
    let (failed, _) =
        write_group_atomically(&[(path.clone(), b"new"), (dir.join("b.json"), b"b")]).unwrap_err();
    assert_eq!(failed, path);
    assert_eq!(std::fs::read(&path).unwrap(), b"previous");
    let names: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(names, ["result.json"]);
    std::fs::remove_dir_all(&dir).unwrap();
}
