//! BYCOMS robot firmware for the ESP32-C3: the shell around the firmware
//! core (`bycoms_agent::firmware`) that `deploy/esp32/README.md` describes.
//!
//! * boot: the flashed configuration (`config.rs`: id, key, tones, WiFi,
//!   gateway; never in the image), the board (`board.rs`: every pin), the
//!   RTC watchdog (a stalled loop resets the chip, which drops the motor
//!   driver's STBY), the heap and the scheduler the radio needs, WiFi
//!   station + DHCP (esp-radio, embassy-net), boot entropy from the
//!   hardware RNG with the radio on;
//! * the sampler, at the highest executor priority: six microphones at
//!   4096 samples/s into one of two static buffers; a full buffer (512
//!   samples each, one 125 ms control period) goes to the main loop, which
//!   hands it back when done;
//! * the main loop: waits for a datagram, a full buffer or the core's
//!   `deadline`, hands the core what came (`handle`) at the time since
//!   boot in µs (`since_boot`, the core's clock), applies its motors and
//!   tone, and sends what it has to send to the gateway (`advance`, then
//!   `poll` until nothing is left). The 500 ms failsafe lives in the core;
//!   this loop makes sure `advance` runs when the core asks.
//!
//! Build (deploy/esp32/README.md): `RUSTC=/usr/bin/rustc RUSTC_BOOTSTRAP=1
//! /usr/bin/cargo build --release -Zbuild-std=core,alloc --target
//! riscv32imc-unknown-none-elf`; flash: `espflash flash --partition-table
//! partitions.csv target/riscv32imc-unknown-none-elf/release/bycoms-esp32c3`.
#![no_std]
#![no_main]

extern crate alloc;

mod board;
mod config;

use board::{Board, Mics, Samples, SAMPLE_RATE};
use bycoms_agent::firmware::{Firmware, FirmwareInput};
use bycoms_protocol::link::LinkKey;
use bycoms_protocol::{Micros, SansIo};
use core::sync::atomic::{AtomicU32, Ordering};
use embassy_executor::Spawner;
use embassy_futures::select::{select3, Either3};
use embassy_net::udp::{PacketMetadata, UdpSocket};
use embassy_net::{IpAddress, IpEndpoint, Runner, StackResources};
use embassy_sync::blocking_mutex::raw::CriticalSectionRawMutex;
use embassy_sync::channel::Channel;
use embassy_time::{Duration, Instant, Timer};
use esp_backtrace as _;
use esp_hal::clock::CpuClock;
use esp_hal::interrupt::Priority;
use esp_hal::rng::Rng;
use esp_hal::rtc_cntl::{Rtc, RwdtStage, RwdtStageAction};
use esp_hal::timer::timg::TimerGroup;
use esp_println::println;
use esp_radio::wifi::sta::StationConfig;
use esp_radio::wifi::{
    AuthenticationMethodConfig, Config as WifiConfig, ControllerConfig, Interface, WifiController,
};
use esp_rtos::embassy::InterruptExecutor;
use static_cell::StaticCell;

esp_bootloader_esp_idf::esp_app_desc!();

/// Sample buffers: full ones to the main loop, empty ones back to the sampler.
type Buffers = Channel<CriticalSectionRawMutex, &'static mut Samples, 2>;
static FULL: Buffers = Channel::new();
static EMPTY: Buffers = Channel::new();
/// Control periods the sampler had no empty buffer for (the loop was late).
static OVERRUNS: AtomicU32 = AtomicU32::new(0);
/// Failed microphone reads (see board.rs).
static FAILED_READS: AtomicU32 = AtomicU32::new(0);

/// The RTC watchdog's timeout: the loop feeds it at least every 100 ms
/// (plus one control period's work, about 35 ms at 160 MHz).
const WATCHDOG: esp_hal::time::Duration = esp_hal::time::Duration::from_millis(1000);

#[esp_hal::main]
async fn main(spawner: Spawner) -> ! {
    let peripherals = esp_hal::init(esp_hal::Config::default().with_cpu_clock(CpuClock::max()));
    esp_alloc::heap_allocator!(#[esp_hal::ram(reclaimed)] size: 64 * 1024);
    esp_alloc::heap_allocator!(size: 36 * 1024);
    let (parts, system) = board::split(peripherals);

    let mut rtc = Rtc::new(system.rtc);
    rtc.rwdt.set_stage_action(RwdtStage::Stage0, RwdtStageAction::ResetSystem);
    rtc.rwdt.set_timeout(RwdtStage::Stage0, WATCHDOG);
    rtc.rwdt.enable();

    let config = match config::read(system.flash) {
        Ok(c) => c,
        Err(e) => halt(&mut rtc, format_args!("configuration: {e}")),
    };
    println!("bycoms robot {}: tone {} Hz, listens for {:?} Hz", config.robot, config.tone, config.others);
    let Board { mics, mut motors, mut speaker } = match Board::new(parts, config.tone) {
        Ok(b) => b,
        Err(e) => halt(&mut rtc, format_args!("board set-up failed: {e}")),
    };

    let timg0 = TimerGroup::new(system.timg0);
    esp_rtos::start(timg0.timer0, system.int0);

    // The sampler runs in an interrupt-mode executor above everything else.
    static SAMPLER: StaticCell<InterruptExecutor<2>> = StaticCell::new();
    let sampler = SAMPLER.init(InterruptExecutor::new(system.int2));
    static BUFFERS: StaticCell<[Samples; 2]> = StaticCell::new();
    let [a, b] = BUFFERS.init([[[0; 512]; 6]; 2]);
    let _ = EMPTY.try_send(a);
    let _ = EMPTY.try_send(b);
    match sample(mics) {
        Ok(task) => sampler.start(Priority::Priority3).spawn(task),
        Err(e) => halt(&mut rtc, format_args!("sampler: {e:?}")),
    }

    // WiFi station and the IP stack.
    let station = station(&config, &mut rtc);
    let interface = Interface::station();
    let controller = match WifiController::new(
        system.wifi,
        ControllerConfig::default().with_initial_config(WifiConfig::Station(station)),
    ) {
        Ok(c) => c,
        Err(e) => halt(&mut rtc, format_args!("WiFi: {e:?}")),
    };
    // With the radio on, the RNG is a true random source.
    let rng = Rng::new();
    let mut entropy = [0u8; 32];
    rng.read(&mut entropy);
    let seed = u64::from(rng.random()) << 32 | u64::from(rng.random());
    static RESOURCES: StaticCell<StackResources<3>> = StaticCell::new();
    let (stack, runner) = embassy_net::new(
        interface,
        embassy_net::Config::dhcpv4(Default::default()),
        RESOURCES.init(StackResources::new()),
        seed,
    );
    for task in [connection(controller).map(|t| spawner.spawn(t)), net(runner).map(|t| spawner.spawn(t))] {
        if let Err(e) = task {
            halt(&mut rtc, format_args!("task: {e:?}"));
        }
    }

    let mut fw = match Firmware::new(config.firmware(), LinkKey::new(&config.key), entropy) {
        Ok(fw) => fw,
        Err(e) => halt(&mut rtc, format_args!("tones: {e}")),
    };
    let gateway = IpEndpoint::new(IpAddress::Ipv4(*config.gateway.ip()), config.gateway.port());
    let (mut rx_meta, mut tx_meta) = ([PacketMetadata::EMPTY; 4], [PacketMetadata::EMPTY; 4]);
    let (mut rx_buf, mut tx_buf) = ([0u8; 1024], [0u8; 1024]);
    let mut socket = UdpSocket::new(stack, &mut rx_meta, &mut rx_buf, &mut tx_meta, &mut tx_buf);
    if let Err(e) = socket.bind(config.port) {
        halt(&mut rtc, format_args!("UDP port {}: {e:?}", config.port));
    }
    motors.enable();
    println!("bycoms robot {}: running; gateway {}", config.robot, config.gateway);

    serve(&mut fw, &mut socket, gateway, &mut motors, &mut speaker, &mut rtc).await
}

/// The WiFi station of the robot's configuration (its network and, if
/// any, its WPA2 password).
fn station(config: &config::Config, rtc: &mut Rtc<'_>) -> StationConfig {
    let mut station = StationConfig::default();
    station = match config.ssid.as_str().try_into() {
        Ok(ssid) => station.with_ssid(ssid),
        Err(e) => halt(rtc, format_args!("ssid: {e:?}")),
    };
    if !config.password.is_empty() {
        match config.password.as_str().try_into() {
            Ok(p) => station = station.with_authentication(AuthenticationMethodConfig::Wpa2Personal(p)),
            Err(e) => halt(rtc, format_args!("password: {e:?}")),
        }
    }
    station
}

/// The control loop: wakes at the core's deadline (and at least every
/// 100 ms, to feed the watchdog), hands the core a datagram, a microphone
/// buffer or the time, applies its motors and tone, and sends what it has
/// to send.
async fn serve(
    fw: &mut Firmware<{ config::LISTENED }>,
    socket: &mut UdpSocket<'_>,
    gateway: IpEndpoint,
    motors: &mut board::Motors,
    speaker: &mut board::Speaker,
    rtc: &mut Rtc<'_>,
) -> ! {
    let mut datagram = [0u8; 512];
    loop {
        rtc.rwdt.feed();
        // Wake at the core's deadline, and at least every 100 ms for the watchdog.
        let wake = Instant::now() + Duration::from_millis(100);
        let deadline = fw.deadline().map_or(wake, |d| Instant::from_micros(d).min(wake));
        let event = select3(socket.recv_from(&mut datagram), FULL.receive(), Timer::at(deadline)).await;
        let now = since_boot();
        match event {
            Either3::First(Ok((n, _from))) => {
                // Any sender: a frame that does not authenticate is counted and dropped.
                let _ = fw.handle(now, FirmwareInput::Datagram(&datagram[..n]));
            }
            Either3::First(Err(_)) => {}
            Either3::Second(samples) => {
                // The core takes the ADC's 12-bit integers as they are; the
                // sampler fills the other buffer meanwhile (a control
                // period's work is a few ms of its 125 ms).
                let _ = fw.handle(now, FirmwareInput::Mics(samples));
                let _ = EMPTY.try_send(samples);
            }
            Either3::Third(()) => fw.advance(now),
        }
        let m = fw.motors();
        motors.apply(m.left, m.right);
        speaker.play(fw.tone().is_some());
        // What is due now (a hello, telemetry, a heartbeat), in the core's buffer.
        fw.advance(now);
        while let Some(frame) = fw.poll() {
            // WiFi drops datagrams too; the link protocol copes.
            let _ = socket.send_to(frame, gateway).await;
        }
    }
}

/// The core's clock: µs since boot (embassy-time's ticks are µs since boot).
fn since_boot() -> Micros {
    Instant::now().as_micros()
}

/// Prints why and waits for the watchdog to reset the chip (motors stay in standby).
fn halt(_rtc: &mut Rtc<'_>, why: core::fmt::Arguments<'_>) -> ! {
    println!("bycoms: {why}; waiting for the watchdog to reset");
    loop {
        core::hint::spin_loop();
    }
}

/// The sampler: six microphones every 1/4096 s, 512 samples a buffer.
#[embassy_executor::task]
async fn sample(mut mics: Mics) {
    let mut buffer = EMPTY.receive().await;
    let start = Instant::now();
    let mut n: u64 = 0;
    let mut i = 0;
    loop {
        n += 1;
        // Exactly 4096 per second on average (a tick is 1 µs).
        Timer::at(start + Duration::from_micros(n * 1_000_000 / u64::from(SAMPLE_RATE))).await;
        for (mic, s) in buffer.iter_mut().zip(mics.read()) {
            mic[i] = s;
        }
        i += 1;
        if i == buffer[0].len() {
            i = 0;
            match EMPTY.try_receive() {
                Ok(next) => {
                    let full = core::mem::replace(&mut buffer, next);
                    let _ = FULL.try_send(full);
                }
                // The loop still holds both: this period is lost.
                Err(_) => OVERRUNS.store(OVERRUNS.load(Ordering::Relaxed).wrapping_add(1), Ordering::Relaxed),
            }
            FAILED_READS.store(mics.failed, Ordering::Relaxed);
        }
    }
}

/// Keeps the station connected.
#[embassy_executor::task]
async fn connection(mut controller: WifiController<'static>) {
    loop {
        match controller.connect_async().await {
            Ok(_) => {
                println!("WiFi connected");
                let _ = controller.wait_for_disconnect_async().await;
                println!("WiFi disconnected");
            }
            Err(e) => println!("WiFi connection failed: {e:?}"),
        }
        Timer::after(Duration::from_secs(2)).await;
    }
}

/// Runs the IP stack.
#[embassy_executor::task]
async fn net(mut runner: Runner<'static, Interface>) {
    runner.run().await
}
