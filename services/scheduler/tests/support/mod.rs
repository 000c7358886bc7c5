//! A scheduler on a free loopback port with a real nats-server and a real store (moto S3 or a directory),
//! and a tiny hand-written campaign: a straight 600 m drive east with a panorama every 20 m.
#![allow(clippy::unwrap_used)]

use std::sync::Arc;
use std::time::Duration;

use plumbline_runtime::{Files, S3Options, Secret};
use plumbline_scheduler::client::Client;
use plumbline_scheduler::service::{self, HttpLimits, Quotas, Scheduler, Tokens};
use plumbline_testkit::{MotoServer, NatsServer};

pub const HAMBURG: &str = "hh-token-0123456789abcdef";
pub const BREMEN: &str = "hb-token-0123456789abcdef";
/// Start of the drive: easting (tile column 5000 at 100 m tiles), northing.
pub const E0: f64 = 500_000.0;
pub const N0: f64 = 5_900_050.0;

/// A running scheduler and what it runs on.
pub struct Harness {
    pub nats: NatsServer,
    /// The S3 server, held so that it runs as long as the harness.
    #[allow(dead_code)]
    pub moto: Option<MotoServer>,
    /// The directory store, held so that it exists as long as the harness.
    #[allow(dead_code)]
    pub dir: Option<tempfile::TempDir>,
    pub files: Files,
    pub store: String,
    pub server: String,
    pub scheduler: Arc<Scheduler>,
    shutdown: Option<tokio::sync::oneshot::Sender<()>>,
}

impl Harness {
    /// Scheduler on moto S3 (`s3://plumbline/pl`).
    pub async fn s3() -> Self {
        let moto = MotoServer::start();
        moto.create_bucket("plumbline");
        let s3 = S3Options {
            endpoint: Some(moto.endpoint()),
            access_key_id: Some("test".into()),
            secret_access_key: Some(Secret::new("test")),
            ..S3Options::default()
        };
        Self::start(
            Files::new(s3),
            "s3://plumbline/pl".into(),
            Some(moto),
            None,
            HttpLimits::default(),
            Quotas::default(),
        )
        .await
    }

    /// Scheduler on a temporary directory.
    pub async fn local() -> Self {
        Self::local_with(HttpLimits::default()).await
    }

    /// Scheduler on a temporary directory, its HTTP server within `limits`.
    pub async fn local_with(limits: HttpLimits) -> Self {
        let dir = tempfile::tempdir().unwrap();
        let store = format!("file://{}", dir.path().display());
        Self::start(Files::default(), store, None, Some(dir), limits, Quotas::default()).await
    }

    /// Scheduler on a temporary directory with other quotas.
    pub async fn local_with_quotas(quotas: Quotas) -> Self {
        let dir = tempfile::tempdir().unwrap();
        let store = format!("file://{}", dir.path().display());
        Self::start(Files::default(), store, None, Some(dir), HttpLimits::default(), quotas).await
    }

    async fn start(
        files: Files,
        store: String,
        moto: Option<MotoServer>,
        dir: Option<tempfile::TempDir>,
        limits: HttpLimits,
        quotas: Quotas,
    ) -> Self {
        let nats = NatsServer::start();
        let tokens = Tokens::from_pairs(&[(HAMBURG, "hamburg"), (BREMEN, "bremen")]).unwrap();
        let client =
            service::connect(&nats.url(), service::NatsAuth::Insecure, "test", Duration::from_secs(10)).await.unwrap();
        let scheduler = Scheduler::start_with(client, files.clone(), &store, tokens, quotas).await.unwrap();
        let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await.unwrap();
        let server = format!("http://{}", listener.local_addr().unwrap());
        let (tx, rx) = tokio::sync::oneshot::channel::<()>();
        tokio::spawn(service::serve_with(listener, scheduler.clone(), limits, async {
            let _ = rx.await;
        }));
        Self { nats, moto, dir, files, store, server, scheduler, shutdown: Some(tx) }
    }

    /// The API as an agency.
    pub fn client(&self, token: &str) -> Client {
        Client::new(&self.server, Secret::new(token)).unwrap()
    }

    /// `{store}/agencies/<agency>/campaigns/<id>/`.
    pub fn campaign_dir(&self, agency: &str, id: &str) -> String {
        format!("{}/agencies/{agency}/campaigns/{id}/", self.store.trim_end_matches('/'))
    }

    /// Upload the tiny campaign's inputs where a manifest of campaign `id` finds them.
    pub async fn upload_inputs(&self, agency: &str, id: &str) {
        let dir = self.campaign_dir(agency, id);
        self.files.write(&format!("{dir}nav/dg.csv"), trajectory_csv().into_bytes()).await.unwrap();
        self.files.write(&format!("{dir}panoramas/index.csv"), panorama_index().into_bytes()).await.unwrap();
    }
}

impl Drop for Harness {
    fn drop(&mut self) {
        if let Some(tx) = self.shutdown.take() {
            let _ = tx.send(());
        }
    }
}

/// 60 s at 10 Hz, 10 m/s due east (heading 90°), flat.
pub fn trajectory_csv() -> String {
    let mut s = String::from(
        "time[s],easting[m],northing[m],height[m],roll[deg],pitch[deg],heading[deg],std_easting[m],\
         std_northing[m],std_height[m],std_roll[deg],std_pitch[deg],std_heading[deg]\n",
    );
    for i in 0..=600 {
        let t = f64::from(i) * 0.1;
        s.push_str(&format!(
            "{:.1},{:.3},{N0:.3},10.0,0.0,0.0,90.0,0.05,0.05,0.1,0.01,0.01,0.02\n",
            1000.0 + t,
            E0 + 10.0 * t
        ));
    }
    s
}

/// A panorama every 2 s from t = 1001 s: eastings 500 010 … 500 590, i.e. tile columns 5000 … 5005.
pub fn panorama_index() -> String {
    let mut s = String::from("image_id,time,file\n");
    for i in 0..30 {
        s.push_str(&format!("p{i:03},{:.1},p{i:03}.jpg\n", 1001.0 + 2.0 * f64::from(i)));
    }
    s
}

/// Tiles of the tiny campaign at 100 m tiles.
pub const TINY_TILES: u64 = 6;

/// The tiny campaign's manifest; `trajectory` and `output` as given.
pub fn manifest(id: &str, trajectory: &str, output: &str) -> String {
    format!(
        r#"version = "1"
crs = 25832
output = "{output}"

[campaign]
id = "{id}"
name = "tiny test drive"

[[trajectory]]
format = "csv"
url = "{trajectory}"

[panoramas]
index = "panoramas/index.csv"
images = "panoramas/"
width_px = 1024
height_px = 512

[panoramas.mount]
lever_arm_m = [0.0, 0.0, -2.0]
boresight_deg = [0.0, 0.0, 0.0]

[tiling]
tile_size_m = 100.0
overlap_m = 10.0
"#
    )
}
