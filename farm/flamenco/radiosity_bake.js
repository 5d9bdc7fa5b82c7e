// SPDX-License-Identifier: GPL-3.0-or-later
//
// Flamenco job type "Radiosity Bake": bakes diffuse global illumination into colour attributes
// with the Radiosity extension, one task per .blend file. Each task runs
//
//     {blender} {blenderArgs} FILE.blend -c radiosity [where the baked file goes] [options]
//
// on a worker through the "blender-render" command (Blender opens the file, then runs the
// extension's command on it). Install: copy this file into the `scripts/` folder beside the
// Flamenco Manager executable and restart the Manager; every worker needs the extension
// installed in its Blender (see farm/README.md).

const JOB_TYPE = {
    label: "Radiosity Bake",
    description: "Bake radiosity into colour attributes: one task per .blend file",
    settings: [
        { key: "files", type: "string", required: false, default: "", visible: "submission",
          description: "The .blend files to bake, as the workers see them, separated by new lines or ';'. " +
                       "Empty: the submitted file" },
        { key: "preset", type: "string", default: "file", visible: "submission",
          choices: ["file", "draft", "preview", "production", "reference"],
          description: "Accuracy preset; 'file' keeps each file's own settings (its Radiosity Bake panel)" },
        { key: "output", type: "string", default: "suffix", visible: "submission",
          choices: ["suffix", "folder", "overwrite"],
          description: "Where each baked file goes: beside its input with the suffix, into the output " +
                       "folder (with the suffix, if any), or over its input" },
        { key: "suffix", type: "string", default: "_baked", visible: "submission",
          description: "Added to each input's name for its baked file (scene.blend -> scene_baked.blend)" },
        { key: "output_folder", type: "string", subtype: "dir_path", default: "", visible: "submission",
          description: "Folder for the baked files when 'output' is 'folder'" },
        { key: "render", type: "bool", default: false, visible: "submission",
          description: "Also render each bake from its scene's camera into a PNG beside the baked file " +
                       "(shown as the job's last rendered image)" },
        { key: "options", type: "string", default: "", visible: "submission",
          description: "More options of `blender -c radiosity --help`, for example " +
                       "\"--patch-size 0.25 --attribute Lighting\"" },

        // Filled in by Flamenco's Blender add-on on submission.
        { key: "blendfile", type: "string", required: false, visible: "web",
          description: "The submitted .blend file, baked when 'files' is empty" },
    ]
};

// Options that say where files go: set by the job's settings, never by `options`.
const PLACEMENT_OPTIONS = ["--input", "-o", "--output", "--output-dir", "--suffix", "--overwrite", "--render",
                           "--summary"];

function compileJob(job) {
    const settings = withDefaults(job.settings);
    const files = filesToBake(settings);
    const placement = placementArgs(settings);
    const options = (settings.preset === "file" ? [] : ["--preset", settings.preset]).concat(extraArgs(settings.options));
    refuseCollisions(settings, files);

    for (const file of files) {
        const task = author.Task(`bake-${path.stem(file)}`, "blender");
        task.addCommand(author.Command("blender-render", {
            exe: "{blender}",
            exeArgs: "{blenderArgs}",
            argsBefore: [],
            blendfile: file,
            args: ["-c", "radiosity"].concat(placement, options),
        }));
        job.addTask(task);
    }
}

// The job's settings, with each one left out taking its default from JOB_TYPE.
function withDefaults(given) {
    const settings = Object.assign({}, given);
    for (const setting of JOB_TYPE.settings) {
        if (settings[setting.key] === undefined && setting.default !== undefined) {
            settings[setting.key] = setting.default;
        }
    }
    return settings;
}

// The listed files, or else the submitted one; every one a .blend file, each once.
function filesToBake(settings) {
    let files = settings.files.split(/[\n;]+/).map((file) => file.trim()).filter((file) => file !== "");
    if (files.length === 0 && settings.blendfile) {
        files = [settings.blendfile];
    }
    if (files.length === 0) {
        throw "No .blend file to bake: list them in 'files', or submit from a saved .blend file";
    }
    for (const file of files) {
        if (!file.toLowerCase().endsWith(".blend")) {
            throw `Not a .blend file: "${file}"`;
        }
    }
    return files.filter((file, index) => files.indexOf(file) === index);
}

function placementArgs(settings) {
    const suffix = settings.suffix;
    let args;
    if (settings.output === "overwrite") {
        args = ["--overwrite"];
    } else if (settings.output === "folder") {
        if (!settings.output_folder) {
            throw "'output' is 'folder': choose the output folder";
        }
        args = ["--output-dir", settings.output_folder].concat(suffix ? ["--suffix", suffix] : []);
    } else if (settings.output === "suffix") {
        if (!suffix) {
            throw "'output' is 'suffix' but the suffix is empty: the baked files would replace their inputs " +
                  "(choose 'overwrite' if that is what you want)";
        }
        args = ["--suffix", suffix];
    } else {
        throw `Unknown output "${settings.output}": choose suffix, folder or overwrite`;
    }
    return settings.render ? args.concat(["--render"]) : args;
}

// Splits `options` as a POSIX shell would split words: blanks separate them, single and double
// quotes group them, a backslash escapes the next character (outside single quotes).
function extraArgs(options) {
    const words = [];
    let word = null;
    let quote = null;
    for (let i = 0; i < options.length; i++) {
        const c = options[i];
        if (quote === "'") {
            if (c === "'") { quote = null; } else { word += c; }
        } else if (c === "\\" && i + 1 < options.length) {
            word = (word || "") + options[++i];
        } else if (quote === '"') {
            if (c === '"') { quote = null; } else { word += c; }
        } else if (c === "'" || c === '"') {
            quote = c;
            word = word || "";
        } else if (/\s/.test(c)) {
            if (word !== null) { words.push(word); word = null; }
        } else {
            word = (word || "") + c;
        }
    }
    if (quote !== null) {
        throw `Unbalanced ${quote} in options: ${options}`;
    }
    if (word !== null) {
        words.push(word);
    }
    for (const word of words) {
        if (PLACEMENT_OPTIONS.indexOf(word.split("=")[0]) >= 0) {
            throw `Option ${word} is set by the job's own settings (files, output, suffix, output folder, render)`;
        }
    }
    return words;
}

// Two inputs of one name would overwrite each other's baked file in the output folder.
function refuseCollisions(settings, files) {
    if (settings.output !== "folder") {
        return;
    }
    const seen = {};
    for (const file of files) {
        const name = path.stem(file) + settings.suffix + ".blend";
        if (seen[name]) {
            throw `"${seen[name]}" and "${file}" would both be baked into ${path.join(settings.output_folder, name)}`;
        }
        seen[name] = file;
    }
}
