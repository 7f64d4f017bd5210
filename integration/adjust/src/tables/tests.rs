use super::*;

/// Read an antenna table of `extra` columns after the required ones, one row per `rows`.
fn antennas(name: &str, extra: &str, rows: &[&str]) -> Result<Vec<Antenna>, String> {
    let path = std::env::temp_dir().join(format!("adjust-{}-{name}.csv", std::process::id()));
    let mut t = format!("id,week,tow,lat,lon,h,c_ee,c_en,c_eu,c_nn,c_nu,c_uu,{extra}\n");
    for (i, r) in rows.iter().enumerate() {
        t += &format!(
            "{i},2300,{},47.0,8.0,500,1e-4,0,0,1e-4,0,1e-4,{r}\n",
            1000 + i
        );
    }
    std::fs::write(&path, t).unwrap();
    let out = read_antennas(&path, 1.0).map_err(|e| e.to_string());
    let _ = std::fs::remove_file(&path);
    out
}

#[test]
fn attitude_sigma_columns_are_checked() {
    let opk = "omega,phi,kappa";
    let e = antennas(
        "two",
        &format!("{opk},sd_omega,sd_phi"),
        &["0,0,90,0.1,0.1"],
    );
    let e = e.unwrap_err();
    assert!(e.contains("two.csv") && e.contains("all three"), "{e}");
    let e = antennas("alone", "sd_omega,sd_phi,sd_kappa", &["0.1,0.1,0.1"]).unwrap_err();
    assert!(e.contains("no `omega,phi,kappa`"), "{e}");
    let cols = format!("{opk},sd_omega,sd_phi,sd_kappa");
    let rows = ["0,0,90,0.01,0.01,0.02", "0,0,90,0.01,0,0.02"];
    let e = antennas("zero", &cols, &rows).unwrap_err();
    assert!(e.contains("line 3") && e.contains("column sd_phi"), "{e}");
    let a = antennas("good", &cols, &rows[..1]).unwrap();
    let s = a[0].rotation_sigma.unwrap().map(f64::to_degrees);
    assert!((s - Vector3::new(0.01, 0.01, 0.02)).norm() < 1e-12, "{s}");
}
