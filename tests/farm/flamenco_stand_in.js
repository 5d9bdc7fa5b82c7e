// A stand-in for the globals a Flamenco Manager gives a job type script (its goja runtime): `author`
// (Task, Command), `path` (Go's filepath: basename, dirname, join, stem) and `print`. Runs the
// script's compileJob on a job read as JSON and prints the job type and the tasks as JSON, or the
// error compileJob threw (which the Manager shows to whoever submitted the job).
//
//     node flamenco_stand_in.js JOB_TYPE_SCRIPT.js '{"settings": {...}}'
"use strict";
const fs = require("fs");
const vm = require("vm");
const posix = require("path").posix;

const [script, jobText] = process.argv.slice(2);
const tasks = [];
const context = vm.createContext({
    author: {
        Task(name, type) {
            const task = { name: name, type: type, commands: [], dependencies: [] };
            return {
                task: task,
                addCommand(command) { task.commands.push(command); },
                addDependency(other) { task.dependencies.push(other.task.name); },
            };
        },
        Command(name, parameters) { return { name: name, parameters: parameters }; },
    },
    path: {
        basename: (p) => posix.basename(p),
        dirname: (p) => posix.dirname(p),
        join: (...parts) => posix.join(...parts),
        stem: (p) => posix.basename(p, posix.extname(p)),
    },
    print: (...words) => process.stderr.write(words.join(" ") + "\n"),
});
vm.runInContext(fs.readFileSync(script, "utf8"), context, { filename: script });
const job = JSON.parse(jobText);
job.addTask = (author) => tasks.push(author.task);
let result;
try {
    vm.runInContext("compileJob", context)(job);
    result = { tasks: tasks };
} catch (error) {
    result = { error: String(error) };
}
result.jobType = vm.runInContext("JOB_TYPE", context);
process.stdout.write(JSON.stringify(result) + "\n");
