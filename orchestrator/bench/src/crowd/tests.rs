use super::*;

fn row(robots: u32, ended: Ended) -> Row {
    Row {
        robots,
        recording_bytes: None,
        ended,
        outcome: Some("robots_exhausted".into()),
        exit_code: Some(3),
        message: None,
        peak_pss_mb: 27.5,
        pss_mb_per_robot: 2.75,
        peak_orchestrator_pss_mb: 9.5,
        ticks: Some(129),
        wall_s: Some(0.94),
        ms_per_tick: Some(7.3),
        clock_ms_per_tick: Some(6.1),
        agents_per_tick: Some(1.5),
        us_per_agent: None,
        peak_files_orchestrator: 256,
        peak_files_agent: 37,
        peak_agents: 10,
        killed_at_shutdown: Some(0),
        files_left: Vec::new(),
        root_segments: Vec::new(),
        processes_left: 0,
        samples: 4,
        sample_ms: 1.5,
    }
}

#[test]
fn sampling_takes_at_most_a_fifth_of_the_time() {
    let due = Instant::now();
    assert_eq!(next_sample_after(due, Duration::from_millis(10)), due + SAMPLE_EVERY);
    assert_eq!(next_sample_after(due, Duration::from_millis(360)), due + Duration::from_millis(1800));
}

#[test]
fn a_refusal_is_its_last_line_without_the_level() {
    let log = " INFO starting\nERROR a launch of 1000 robots needs about 27064 open files\n\n";
    assert_eq!(last_words(log).as_deref(), Some("a launch of 1000 robots needs about 27064 open files"));
    assert_eq!(last_words("\n  \n"), None);
}

#[test]
fn the_root_segment_is_told_from_a_launch_s_leftovers() {
    assert!(is_root_segment("/dev/shm/iox2_crowd-1-10_9204dd_node.0_10_0.global_mgmt"));
    assert!(!is_root_segment("/dev/shm/bycoms-swarm.crowd-1-10.crowd-1-10.lock"));
}

#[test]
fn the_table_has_a_row_per_launch_and_says_why_one_did_not_run() {
    let mut refused = row(1000, Ended::Refused);
    refused.message = Some("needs about 27064 open files".into());
    let mut left = row(10, Ended::Ran);
    left.files_left = vec!["/dev/shm/x".into()];
    let text = table(&[left, row(100, Ended::TimedOut), refused]);
    let lines: Vec<&str> = text.lines().collect();
    assert!(lines[2].trim_start().starts_with("10 ") && lines[2].contains("2.75"), "{text}");
    assert!(lines[3].ends_with("(TimedOut)"), "{text}");
    assert!(lines[4].contains("1000 refused: needs about 27064 open files"), "{text}");
    assert!(text.contains("10 robots: 1 files left (removed): /dev/shm/x"), "{text}");
}

#[test]
fn a_recorded_launch_is_set_beside_the_same_launch_unrecorded() {
    let plain = row(100, Ended::Ran);
    let mut recorded = row(100, Ended::Ran);
    recorded.recording_bytes = Some(2_500_000);
    recorded.ms_per_tick = Some(8.03);
    let text = table(&[plain, recorded]);
    assert!(
        text.contains("100 robots recorded: 2.5 MB, 8.03 ms/tick against 7.30 unrecorded (+10.0 %)"),
        "{text}"
    );
    assert!(text.lines().nth(3).is_some_and(|l| l.trim_start().starts_with("100      2.5 ")), "{text}");
}

#[test]
fn each_size_run_more_than_once_gets_its_medians_of_the_unrecorded_launches_that_ran() {
    let ran =
        |robots, us, ms| Row { us_per_agent: Some(us), ms_per_tick: Some(ms), ..row(robots, Ended::Ran) };
    let recorded = Row { recording_bytes: Some(1_000), ..ran(10, 99.0, 9.9) };
    let failed = Row { us_per_agent: Some(50.0), ..row(10, Ended::Failed) };
    let rows =
        [ran(10, 6.0, 0.30), recorded, ran(10, 4.0, 0.20), failed, ran(300, 3.0, 0.40), ran(10, 5.0, 0.25)];
    let medians = medians(&rows);
    assert_eq!(medians.len(), 1, "300 robots ran once: no medians");
    let m = &medians[0];
    assert_eq!((m.robots, m.launches), (10, 3), "the recorded and the failed launch are not counted");
    assert_eq!(m.us_per_agent, Some(Spread { median: 5.0, min: 4.0, max: 6.0 }));
    assert_eq!(m.ms_per_tick, Some(Spread { median: 0.25, min: 0.20, max: 0.30 }));
    assert_eq!(
        m.line(),
        "10 robots, median of 3 launches (least–greatest): µs/agent 5.0 (4.0–6.0), ms/tick 0.250 (0.200–0.300)\n"
    );
    let table = table(&rows);
    assert!(table.contains(&m.line()), "the table ends with it");
    assert!(!table.contains("300 robots, median"), "a size run once gets no line");
}
