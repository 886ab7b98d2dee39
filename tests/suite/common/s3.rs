//! A real S3-compatible server for the run-store tests: moto's server
//! (`pip install 'moto[server]==5.2.1'`, as `.ci/run` does) started on a
//! free loopback port and killed when dropped, or the one named by
//! `SINSCAL_TEST_S3_ENDPOINT` (which must let anyone create a bucket, as
//! moto does). Without either the tests fail, saying what to install.

use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use object_store::aws::{AmazonS3, AmazonS3Builder};
use object_store::path::Path as Key;
use object_store::{ObjectStore, PutPayload};
use sinscal_server::runstore::{RunStoreSpec, S3Location};

/// What the tests tell a machine without an S3 server.
const INSTALL: &str = "the run-store tests need an S3-compatible server: install moto's \
    (`python3 -m pip install 'moto[server]==5.2.1'`, which provides `moto_server`), or set \
    SINSCAL_TEST_S3_ENDPOINT to the URL of one";

/// Credentials any moto server takes (it checks no signatures).
const KEY_ID: &str = "sinscal-test";
const SECRET: &str = "sinscal-test-secret";
const REGION: &str = "us-east-1";

pub struct S3Server {
    pub endpoint: String,
    child: Option<Child>,
}

impl Drop for S3Server {
    fn drop(&mut self) {
        if let Some(child) = &mut self.child {
            let _ = child.kill();
            let _ = child.wait();
        }
    }
}

fn free_port() -> u16 {
    std::net::TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port()
}

/// `moto_server`, or moto's module when its script is not on PATH; with
/// `check_credentials`, moto authenticates every request against its own
/// (empty) IAM, so that any access key is refused as unknown.
fn spawn_moto(port: u16, check_credentials: bool) -> Child {
    let port = port.to_string();
    let quiet = |c: &mut Command| {
        c.stdin(Stdio::null())
            .stdout(Stdio::null())
            .stderr(Stdio::null());
        if check_credentials {
            c.env("INITIAL_NO_AUTH_ACTION_COUNT", "0");
        }
    };
    let mut script = Command::new("moto_server");
    script.args(["-H", "127.0.0.1", "-p", &port]);
    quiet(&mut script);
    match script.spawn() {
        Ok(child) => child,
        Err(_) => {
            let mut module = Command::new("python3");
            module.args(["-m", "moto.server", "-H", "127.0.0.1", "-p", &port]);
            quiet(&mut module);
            module
                .spawn()
                .unwrap_or_else(|e| panic!("starting moto_server: {e}; {INSTALL}"))
        }
    }
}

impl S3Server {
    /// The server of `SINSCAL_TEST_S3_ENDPOINT`, or a new moto server,
    /// once it answers.
    pub async fn start() -> S3Server {
        if let Ok(endpoint) = std::env::var("SINSCAL_TEST_S3_ENDPOINT") {
            return S3Server {
                endpoint: endpoint.trim_end_matches('/').to_string(),
                child: None,
            };
        }
        S3Server::spawn(false).await
    }

    /// A new moto server that refuses every access key (none is known to
    /// it), as a real store refuses wrong credentials.
    pub async fn start_refusing_credentials() -> S3Server {
        S3Server::spawn(true).await
    }

    async fn spawn(check_credentials: bool) -> S3Server {
        let port = free_port();
        let mut server = S3Server {
            endpoint: format!("http://127.0.0.1:{port}"),
            child: Some(spawn_moto(port, check_credentials)),
        };
        let http = reqwest::Client::new();
        let start = Instant::now();
        loop {
            if http.get(&server.endpoint).send().await.is_ok() {
                return server;
            }
            if let Some(status) = server.child.as_mut().unwrap().try_wait().unwrap() {
                panic!("moto_server exited ({status}) before answering; {INSTALL}");
            }
            assert!(
                start.elapsed() < Duration::from_secs(60),
                "moto_server did not answer on {} within a minute; {INSTALL}",
                server.endpoint
            );
            tokio::time::sleep(Duration::from_millis(50)).await;
        }
    }

    /// Kills the server now (a store that stops answering).
    pub fn kill(&mut self) {
        if let Some(child) = &mut self.child {
            let _ = child.kill();
            let _ = child.wait();
        }
        self.child = None;
    }

    /// Creates a bucket named after `stem` and unique to the call.
    pub async fn create_bucket(&self, stem: &str) -> String {
        let bucket = format!(
            "{stem}-{}",
            &uuid::Uuid::new_v4().simple().to_string()[..12]
        );
        let r = reqwest::Client::new()
            .put(format!("{}/{bucket}", self.endpoint))
            .header("content-length", "0")
            .send()
            .await
            .unwrap();
        assert!(
            r.status().is_success(),
            "creating bucket {bucket}: {}",
            r.status()
        );
        bucket
    }

    /// The settings a server needs to reach this one (as the AWS_*
    /// variables would give them).
    pub fn options(&self) -> Vec<(String, String)> {
        [
            ("aws_endpoint", self.endpoint.as_str()),
            ("aws_allow_http", "true"),
            ("aws_access_key_id", KEY_ID),
            ("aws_secret_access_key", SECRET),
            ("aws_region", REGION),
        ]
        .iter()
        .map(|(k, v)| (k.to_string(), v.to_string()))
        .collect()
    }

    /// The same settings as the environment of a `sinscal serve` process.
    pub fn env(&self) -> Vec<(&'static str, String)> {
        vec![
            ("AWS_ENDPOINT_URL", self.endpoint.clone()),
            ("AWS_ALLOW_HTTP", "true".into()),
            ("AWS_ACCESS_KEY_ID", KEY_ID.into()),
            ("AWS_SECRET_ACCESS_KEY", SECRET.into()),
            ("AWS_REGION", REGION.into()),
        ]
    }

    /// A run store in `bucket` under `prefix`, with the sweep's timing.
    pub fn run_store(
        &self,
        bucket: &str,
        prefix: &str,
        grace: Duration,
        sweep_every: Duration,
    ) -> RunStoreSpec {
        let mut location = S3Location::new(bucket, prefix);
        location.orphan_grace = grace;
        location.sweep_every = sweep_every;
        location.options = self.options();
        RunStoreSpec::S3(location)
    }

    /// A client of `bucket`, to look at and plant objects.
    pub fn client(&self, bucket: &str) -> Bucket {
        let mut b = AmazonS3Builder::new().with_bucket_name(bucket);
        for (k, v) in self.options() {
            b = b.with_config(k.parse().unwrap(), v);
        }
        Bucket(b.build().unwrap())
    }
}

pub struct Bucket(pub AmazonS3);

impl Bucket {
    /// Every key under `prefix`, sorted.
    pub async fn keys(&self, prefix: &str) -> Vec<String> {
        use futures_util::TryStreamExt;
        let prefix = Key::from(prefix);
        let mut keys: Vec<String> = self
            .0
            .list(Some(&prefix))
            .map_ok(|m| m.location.to_string())
            .try_collect()
            .await
            .unwrap();
        keys.sort();
        keys
    }

    pub async fn put(&self, key: &str, bytes: &'static [u8]) {
        self.0
            .put(&Key::from(key), PutPayload::from(bytes))
            .await
            .unwrap();
    }

    pub async fn exists(&self, key: &str) -> bool {
        match self.0.head(&Key::from(key)).await {
            Ok(_) => true,
            Err(object_store::Error::NotFound { .. }) => false,
            Err(e) => panic!("head {key}: {e}"),
        }
    }
}
