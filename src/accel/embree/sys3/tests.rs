use super::*;

#[test]
fn linked_library_has_the_bindings_major_version() {
    // Struct layouts are stable within a major version (build.rs checks
    // the configuration that changes them), so a 3.x library fits.
    let d = Device::new(None).unwrap();
    let v = unsafe { rtcGetDeviceProperty(d.raw, RTC_DEVICE_PROPERTY_VERSION) };
    assert_eq!(v / 10000, RTC_VERSION_MAJOR as isize);
    assert!(d.version().starts_with(&format!("{RTC_VERSION_MAJOR}.")));
}

#[test]
fn embree_errors_reach_the_caller_with_embrees_message() {
    let d = Device::new(None).unwrap();
    let s = d.new_scene(EmbreeQuality::Medium, false, false).unwrap();
    let positions = [PackedVec3::ZERO, PackedVec3::X, PackedVec3::Y];
    // SAFETY: not shared, so Embree copies the arrays.
    let g = unsafe { d.new_triangles(&positions, false, &[[0, 1, 2]], EmbreeQuality::Medium) };
    let g = g.unwrap();
    d.attach(&s, &g, 3).unwrap();
    // The same id twice is an invalid operation.
    let err = d.attach(&s, &g, 3).unwrap_err();
    let EmbreeError::Call {
        call,
        code,
        reports,
    } = &err
    else {
        panic!("{err}");
    };
    assert_eq!(
        (*call, *code),
        ("rtcAttachGeometryByID", ErrorCode::InvalidOperation)
    );
    let reported = |r: &Report| r.code == ErrorCode::InvalidOperation && !r.message.is_empty();
    assert!(matches!(reports.as_slice(), [r] if reported(r)), "{err}");
    // "rtcAttachGeometryByID: invalid geometry ID provided (invalid operation)"
    let message = err.to_string();
    assert!(message.starts_with("rtcAttachGeometryByID: "), "{message}");
    assert!(message.ends_with(" (invalid operation)"), "{message}");
    // Errors are consumed by the check that reports them.
    d.check("nothing").unwrap();
    // A configuration Embree cannot parse fails the device creation.
    let err = Device::new(Some("threads=abc")).err().unwrap();
    assert!(matches!(err, EmbreeError::Device { .. }), "{err}");
    assert!(
        err.to_string().starts_with("rtcNewDevice failed: "),
        "{err}"
    );
    // One C cannot be handed never reaches Embree.
    let err = Device::new(Some("threads=1\0")).err().unwrap();
    assert!(matches!(err, EmbreeError::ConfigHasNul), "{err}");
}
