//! `fmu-pack`: package the project's FMUs. It links no model: it loads this machine's build of
//! each library and asks it (`fmuCoreDescription`) for its `modelDescription.xml`, so the
//! description comes from the code packaged beside it, and checks that every library it packs,
//! for any platform, exports all 44 FMI 2.0 and 75 FMI 3.0 functions (`fmpy validate` never
//! loads the binary). `--fmi 3` packs an FMI 3.0 archive from the same library.
//!
//! ```text
//! fmu-pack fmu --lib target/release/libfmu_plant.so --out dist/plant.fmu
//! fmu-pack fmu --lib target/release/libfmu_controller.so --resources dist/hinf_sf --out dist/hinf_sf.fmu
//! fmu-pack fmu --lib target/release/libfmu_plant.so --binary win64=…/fmu_plant.dll --out dist/plant.fmu
//! fmu-pack description --lib target/release/libfmu_plant.so --xml modelDescription/plant.xml --readme README.md --tag plant-variables
//! fmu-pack platforms --fmu dist/plant.fmu --fmu dist/linux-aarch64/plant.fmu --readme README.md --tag platform
//! fmu-pack splice --from results/report.md --section "## Summary" --readme README.md --tag comparison
//! ```

use clap::{Parser, Subcommand};
use fmu_core::ModelDescription;
use fmu_pack::binary;
use fmu_pack::package::{self, Binary};
use std::ffi::{CStr, CString};
use std::os::raw::{c_char, c_int};
use std::path::{Path, PathBuf};
use std::process::ExitCode;

#[derive(Parser)]
#[command(about = "Package the project's FMUs")]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Build one .fmu from a compiled FMU library and (optionally) its resource directory.
    Fmu {
        /// The cdylib cargo built for this machine (lib<crate>.so): it describes the FMU and goes
        /// in this machine's platform folder unless a --binary names that folder.
        #[arg(long)]
        lib: PathBuf,
        /// The same library built for another platform, as FOLDER=FILE (win64=fmu_plant.dll,
        /// linux64=an AArch64 libfmu_plant.so for an ARM FMU). Checked without loading it: the
        /// folder's format and architecture, and the 44 fmi2 exports.
        #[arg(long = "binary", value_name = "FOLDER=FILE")]
        binaries: Vec<String>,
        /// Directory whose files become resources/ (e.g. dist/hinf_sf with controller.json).
        #[arg(long)]
        resources: Option<PathBuf>,
        /// The FMI version of the archive: 2 (binaries/linux64, win64) or 3 (binaries/
        /// x86_64-linux, aarch64-linux, x86_64-windows; FMI 3.0's modelDescription.xml). The
        /// same library serves both.
        #[arg(long, default_value_t = 2, value_parser = clap::value_parser!(u8).range(2..=3))]
        fmi: u8,
        #[arg(long)]
        out: PathBuf,
    },
    /// Write a library's modelDescription.xml and/or splice its variable table into a README.
    Description {
        #[arg(long)]
        lib: PathBuf,
        #[arg(long)]
        resources: Option<PathBuf>,
        #[arg(long)]
        xml: Option<PathBuf>,
        /// Also write FMI 3.0's modelDescription.xml here.
        #[arg(long)]
        xml3: Option<PathBuf>,
        #[arg(long)]
        readme: Option<PathBuf>,
        /// Marker name in the README: `<!-- TAG:begin -->` … `<!-- TAG:end -->`.
        #[arg(long)]
        tag: Option<String>,
    },
    /// Print the platforms the FMUs' libraries run on (format, architecture, the glibc or the
    /// DLLs they need), and/or put that table in a README.
    Platforms {
        /// One .fmu standing for every FMU of its folder.
        #[arg(long, required = true)]
        fmu: Vec<PathBuf>,
        #[arg(long)]
        readme: Option<PathBuf>,
        /// Marker name in the README.
        #[arg(long, requires = "readme")]
        tag: Option<String>,
    },
    /// Splice a file a tool wrote (a table, a report section) into a README, so its figures are
    /// the tool's and never typed by hand.
    Splice {
        /// The markdown file, e.g. dist/synthesis.md or results/report.md.
        #[arg(long)]
        from: PathBuf,
        /// Only this section of it: from the line equal to the heading (e.g. `## Summary`) to
        /// the next heading of the same or a higher level, both excluded.
        #[arg(long)]
        section: Option<String>,
        #[arg(long)]
        readme: PathBuf,
        /// Marker name in the README: `<!-- TAG:begin -->` … `<!-- TAG:end -->`.
        #[arg(long)]
        tag: String,
    },
}

/// Where FMI 3.0 keeps the terminals in an archive (FMI 3.0.2 §2.5).
const TERMINALS: &str = "terminalsAndIcons/terminalsAndIcons.xml";

struct Library(libloading::Library);

impl Library {
    fn load(path: &Path) -> Result<Self, String> {
        // SAFETY: our own freshly built library, without initialisers that have effects.
        let lib = unsafe { libloading::Library::new(path) }
            .map_err(|e| format!("cannot load {}: {e}", path.display()))?;
        Ok(Library(lib))
    }

    /// `format` 0: FMI 2.0's modelDescription.xml, 1: Markdown variable table, 2: FMI 3.0's
    /// modelDescription.xml, 3: FMI 3.0's terminalsAndIcons.xml (empty without terminals).
    fn document(&self, resources: Option<&Path>, format: c_int) -> Result<String, String> {
        type Describe = unsafe extern "C" fn(*const c_char, c_int) -> *mut c_char;
        type Free = unsafe extern "C" fn(*mut c_char);
        let dir = resources.map(|p| CString::new(p.to_string_lossy().as_bytes()).unwrap());
        unsafe {
            let describe = self
                .0
                .get::<Describe>(b"fmuCoreDescription")
                .map_err(|e| format!("library has no fmuCoreDescription: {e}"))?;
            let free = self
                .0
                .get::<Free>(b"fmuCoreFreeString")
                .map_err(|e| format!("library has no fmuCoreFreeString: {e}"))?;
            let p = describe(
                dir.as_ref().map_or(std::ptr::null(), |d| d.as_ptr()),
                format,
            );
            if p.is_null() {
                return Err("the library could not describe itself (see the message above)".into());
            }
            let text = CStr::from_ptr(p).to_string_lossy().into_owned();
            free(p);
            Ok(text)
        }
    }
}

/// `modelIdentifier` from the XML the library produced.
fn model_identifier(xml: &str) -> Result<String, String> {
    let key = "modelIdentifier=\"";
    let i = xml
        .find(key)
        .ok_or("modelDescription.xml has no modelIdentifier")?
        + key.len();
    let j = xml[i..].find('"').ok_or("unterminated modelIdentifier")? + i;
    Ok(xml[i..j].to_string())
}

fn read_dir_files(dir: &Path) -> Result<Vec<(String, Vec<u8>)>, String> {
    let mut files = Vec::new();
    let entries =
        std::fs::read_dir(dir).map_err(|e| format!("cannot list {}: {e}", dir.display()))?;
    for entry in entries {
        let path = entry.map_err(|e| e.to_string())?.path();
        if path.is_file() {
            let name = path.file_name().unwrap().to_string_lossy().into_owned();
            files.push((
                name,
                std::fs::read(&path).map_err(|e| format!("cannot read {}: {e}", path.display()))?,
            ));
        }
    }
    files.sort();
    Ok(files)
}

fn run(cli: Cli) -> Result<(), String> {
    match cli.command {
        Command::Fmu {
            lib,
            binaries,
            resources,
            fmi,
            out,
        } => {
            let library = Library::load(&lib)?;
            let xml = library.document(resources.as_deref(), if fmi == 3 { 2 } else { 0 })?;
            let id = model_identifier(&xml)?;
            let files = match &resources {
                Some(dir) => read_dir_files(dir)?,
                None => Vec::new(),
            };
            let mut libs = Vec::new();
            for spec in &binaries {
                let (folder, path) = spec
                    .split_once('=')
                    .ok_or_else(|| format!("--binary {spec}: expected FOLDER=FILE"))?;
                libs.push(Binary::read(folder, Path::new(path))?);
            }
            let host = package::host_platform(fmi)?;
            let folders = if fmi == 3 {
                &package::PLATFORMS3[..]
            } else {
                &package::PLATFORMS[..]
            };
            if let Some(b) = libs
                .iter()
                .find(|b| !folders.iter().any(|p| p.folder == b.platform.folder))
            {
                return Err(format!(
                    "binaries/{} is not a platform folder of FMI {fmi}.0",
                    b.platform.folder
                ));
            }
            if !libs.iter().any(|b| b.platform.folder == host.folder) {
                libs.insert(0, Binary::read(host.folder, &lib)?);
            }
            // FMI 3.0's terminals, where the model has them.
            let mut extra = Vec::new();
            if fmi == 3 {
                let terminals = library.document(resources.as_deref(), 3)?;
                if !terminals.is_empty() {
                    extra.push((TERMINALS.to_string(), terminals.into_bytes()));
                }
            }
            package::write_fmu(&out, &xml, &id, &libs, &files, &extra)?;
            let folders: Vec<&str> = libs.iter().map(|b| b.platform.folder).collect();
            println!(
                "wrote {} (modelIdentifier {id}, binaries {}, {} resource file(s))",
                out.display(),
                folders.join(" "),
                files.len()
            );
            Ok(())
        }
        Command::Description {
            lib,
            resources,
            xml,
            xml3,
            readme,
            tag,
        } => {
            binary::read_library(&lib)?.1.require_exports(&lib)?;
            let library = Library::load(&lib)?;
            if let Some(path) = xml {
                std::fs::write(&path, library.document(resources.as_deref(), 0)?)
                    .map_err(|e| format!("cannot write {}: {e}", path.display()))?;
                println!("wrote {}", path.display());
            }
            if let Some(path) = xml3 {
                std::fs::write(&path, library.document(resources.as_deref(), 2)?)
                    .map_err(|e| format!("cannot write {}: {e}", path.display()))?;
                println!("wrote {}", path.display());
            }
            if let Some(path) = readme {
                let table = library.document(resources.as_deref(), 1)?;
                splice_readme(&path, tag, &table)?;
            }
            Ok(())
        }
        Command::Platforms { fmu, readme, tag } => {
            let mut fmus = Vec::new();
            for path in &fmu {
                fmus.push((path.display().to_string(), package::fmu_binaries(path)?));
            }
            let note = fmu_pack::platform_note(&fmus);
            print!("{note}");
            if let Some(path) = readme {
                splice_readme(&path, tag, &note)?;
            }
            Ok(())
        }
        Command::Splice {
            from,
            section,
            readme,
            tag,
        } => {
            let text = std::fs::read_to_string(&from)
                .map_err(|e| format!("cannot read {}: {e}", from.display()))?;
            let content = match section {
                Some(heading) => fmu_pack::markdown_section(&text, &heading)
                    .ok_or_else(|| format!("{}: no section '{heading}'", from.display()))?,
                None => text,
            };
            splice_readme(&readme, Some(tag), &content)
        }
    }
}

/// Replace what stands between the README's `tag` markers with `content`.
fn splice_readme(path: &Path, tag: Option<String>, content: &str) -> Result<(), String> {
    let tag = tag.ok_or("--readme needs --tag")?;
    let doc = std::fs::read_to_string(path)
        .map_err(|e| format!("cannot read {}: {e}", path.display()))?;
    let doc = ModelDescription::splice_into(&doc, &tag, content).map_err(|e| e.to_string())?;
    std::fs::write(path, doc).map_err(|e| format!("cannot write {}: {e}", path.display()))?;
    println!("updated {} ({tag})", path.display());
    Ok(())
}

fn main() -> ExitCode {
    match run(Cli::parse()) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("fmu-pack: {e}");
            ExitCode::FAILURE
        }
    }
}
