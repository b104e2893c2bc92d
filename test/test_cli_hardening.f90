!> Tests of the `holosym` tool against hostile use, through the executable: every size
!! option has a range and no value is reported that the user did not give; output that
!! cannot be written (a full device, a closed standard output, a file-size limit) is a
!! failure; step counts that overflow or round to zero, numbers and quotients out of
!! range, empty values and unsafe directory names are rejected or handled without a
!! shell; reference and benchmark files are read strictly; --steps bounds every part of
!! `extremes`; and a bounded randomized test of bad argument vectors on every command.
module test_cli_hardening
    use, intrinsic :: iso_fortran_env, only: int64
    use holosym_kinds, only: wp, wp_is_double
    use holosym_status_codes, only: int_str
    use holosym_testing, only: test_case_t, new_test, test_error_t, check, overflow_traps
    use holosym_test_commands, only: command_result_t, text_line_t, run_holosym, run_shell, &
        shell_quote, holosym_executable, scratch_path, read_lines, write_lines, file_exists, &
        any_line_contains, words
    implicit none
    private
    public :: cli_hardening_tests

    !> Exit statuses of the tool.
    integer, parameter :: exit_failure = 1, exit_usage = 2
    !> Seconds a command of the randomized test may run (`timeout`).
    integer, parameter :: time_limit = 20
    !> Argument vectors of the randomized test.
    integer, parameter :: random_vectors = 300

contains

    !> The tests of this suite.
    function cli_hardening_tests() result(tests)
        type(test_case_t), allocatable :: tests(:)
        tests = [ &
            new_test("size_options_have_ranges", size_ranges), &
            new_test("unwritable_output_fails", unwritable_output), &
            new_test("unwritable_ensemble_figures_bench_files", unwritable_files), &
            new_test("devices_as_input_files_refused", device_inputs), &
            new_test("step_counts_checked", step_counts), &
            new_test("directories_made_without_a_shell", no_shell), &
            new_test("children_and_paths_without_a_shell", no_shell_anywhere), &
            new_test("reference_file_read_strictly", reference_file), &
            new_test("quotients_and_numbers_out_of_range", numbers_out_of_range), &
            new_test("empty_values_rejected", empty_values), &
            new_test("extremes_steps_bound_every_part", extremes_steps_bound), &
            new_test("tiny_and_absurd_steps", tiny_and_absurd_steps), &
            new_test("randomized_bad_arguments", randomized_arguments) &
            ]
    end function cli_hardening_tests

    ! ------------------------------------------------------------------ helpers

    !> No runtime error, backtrace or signal report on standard error.
    logical function clean(result)
        type(command_result_t), intent(in) :: result
        clean = .not. (any_line_contains(result%err, "Fortran runtime error") .or. &
                       any_line_contains(result%err, "Backtrace") .or. &
                       any_line_contains(result%err, "Program received signal") .or. &
                       any_line_contains(result%err, "Error termination") .or. &
                       any_line_contains(result%err, "Error allocating"))
    end function clean

    !> The first line of standard error, for messages ("" when there is none).
    function first_error(result) result(text)
        type(command_result_t), intent(in) :: result
        character(len=:), allocatable :: text
        text = ""
        if (size(result%err) > 0) text = result%err(1)%text
    end function first_error

    !> Run `holosym` with `args`; expect `code`, a clean message on standard error that
    !! holds every fragment of `texts`, and none of `absent`.
    subroutine expect(error, args, code, texts, absent)
        type(test_error_t), allocatable, intent(inout) :: error
        character(len=*), intent(in) :: args(:)
        integer, intent(in) :: code
        character(len=*), intent(in) :: texts(:)
        character(len=*), intent(in), optional :: absent(:)
        type(command_result_t) :: result
        character(len=:), allocatable :: label
        integer :: k
        if (allocated(error)) return
        label = ""
        do k = 1, size(args)
            label = label // " " // trim(args(k))
        end do
        call run_holosym(args, result)
        call check(error, result%exit_code == code, "holosym" // label // ": exit " // &
            int_str(result%exit_code) // ", expected " // int_str(code) // " (" // &
            first_error(result) // ")")
        call check(error, clean(result), "holosym" // label // ": not a clean error: " // &
            first_error(result))
        do k = 1, size(texts)
            call check(error, any_line_contains(result%err, trim(texts(k))), "holosym" // &
                label // ": no message with '" // trim(texts(k)) // "': " // first_error(result))
        end do
        if (present(absent)) then
            do k = 1, size(absent)
                call check(error, .not. any_line_contains(result%err, trim(absent(k))), &
                    "holosym" // label // ": the message shows '" // trim(absent(k)) // &
                    "': " // first_error(result))
            end do
        end if
    end subroutine expect

    !> Run a shell command line that starts the executable (given as EXE in `line`, by its
    !! absolute path: the line may change directory first).
    subroutine shell_with_exe(line, result)
        character(len=*), intent(in) :: line
        type(command_result_t), intent(out) :: result
        character(len=:), allocatable :: command
        integer :: at
        command = line
        at = index(command, "EXE")
        do while (at > 0)
            command = command(:at - 1) // shell_quote(absolute(holosym_executable())) // &
                command(at + 3:)
            at = index(command, "EXE")
        end do
        call run_shell(command, result)
    end subroutine shell_with_exe

    !> `path` made absolute with the working directory ($PWD) when it is relative.
    function absolute(path) result(full)
        character(len=*), intent(in) :: path
        character(len=:), allocatable :: full
        character(len=4096) :: directory
        integer :: length, stat
        full = path
        if (len(path) == 0) return
        if (path(1:1) == "/") return
        call get_environment_variable("PWD", directory, length, stat)
        if (stat == 0 .and. length > 0) full = trim(directory) // "/" // path
    end function absolute

    ! ------------------------------------------------------------------ 1, 2, 14

    !> M, N, G, Mmax, Nmax and every other size option reject values outside their
    !! documented ranges with exit 2, naming the range and the value as given; nothing
    !! allocates, nothing reports a value the user did not give (an overflowed default G).
    subroutine size_ranges(error)
        type(test_error_t), allocatable, intent(out) :: error
        call expect(error, words("simulate", "--M", "2147483647", "--N", "0", "--G", "1", &
            "--steps", "1"), exit_usage, [character(len=32) :: "--M", "1..30", "'2147483647'"])
        call expect(error, words("simulate", "--M", "2", "--N", "2147483647", "--steps", "1"), &
            exit_usage, [character(len=32) :: "--N", "0..30"], &
            [character(len=32) :: "-2147483648", "G ="])
        call expect(error, words("simulate", "--G", "65"), exit_usage, &
            [character(len=32) :: "--G", "1..64", "'65'"])
        call expect(error, words("simulate", "--M", "5", "--G", "3"), exit_usage, &
            [character(len=32) :: "G = 3", "N + 1 = 5", "M - 1"])
        call expect(error, words("simulate", "--every", "0"), exit_usage, &
            [character(len=32) :: "--every", "1..2147483647"])
        call expect(error, words("simulate", "--steps", "-1"), exit_usage, &
            [character(len=32) :: "--steps", "0..2147483647"])
        call expect(error, words("tables", "--Mmax", "2147483647", "--Nmax", "2147483647"), &
            exit_usage, [character(len=32) :: "--Mmax", "1..30"])
        call expect(error, words("tables", "--Mmax", "100000"), exit_usage, &
            [character(len=32) :: "--Mmax", "1..30", "'100000'"])
        call expect(error, words("tables", "--Nmax", "31"), exit_usage, &
            [character(len=32) :: "--Nmax", "0..30"])
        call expect(error, words("bench", "--Mmax", "13"), exit_usage, &
            [character(len=32) :: "--Mmax", "1..12"])
        call expect(error, words("bench", "--budget", "1e9"), exit_usage, &
            [character(len=32) :: "--budget", "(0, 3600]"])
        call expect(error, words("extremes", "--max-order", "16"), exit_usage, &
            [character(len=32) :: "--max-order", "1..15"])
        call expect(error, words("simulate", "--system", "chain", "--links", "100001"), &
            exit_usage, [character(len=32) :: "--links", "1..100000"])
        call expect(error, words("ensemble", "--perturb", "1000001", "--output", "x.csv"), &
            exit_usage, [character(len=32) :: "--perturb", "1..1000000"])
        call expect(error, words("ensemble", "--perturb", "2", "--M", "2147483647", &
            "--output", "x.csv"), exit_usage, [character(len=32) :: "--M", "1..30"], &
            [character(len=32) :: "-2147483648", "G ="])
        call expect(error, words("ensemble", "--perturb", "2", "--threads", "100000", &
            "--output", "x.csv"), exit_usage, [character(len=32) :: "--threads", "1..256"])
        call expect(error, words("ensemble", "--perturb", "2", "--T", "1e300", "--h", &
            "1e-300", "--output", "x.csv"), exit_usage, [character(len=32) :: "T/h"])
        call expect(error, words("figures", "--long-steps", "2147483647", "--out", "f"), &
            exit_usage, [character(len=32) :: "--long-steps", "100..100000000"])
        call expect(error, words("bench", "--scaling-point", "100001"), exit_usage, &
            [character(len=32) :: "--scaling-point", "1..100000"])
        call large_chain(error)
    contains
        !> A chain of 5000 links (Phi would be 5000 x 10^4 dense): one step, no crash.
        subroutine large_chain(error)
            type(test_error_t), allocatable, intent(inout) :: error
            type(command_result_t) :: result
            if (allocated(error)) return
            call shell_with_exe("timeout 60 EXE simulate --system chain --links 5000 " // &
                "--steps 1 > /dev/null", result)
            call check(error, result%exit_code == 0 .and. clean(result), "simulate " // &
                "--system chain --links 5000 --steps 1: exit " // int_str(result%exit_code) &
                // ": " // first_error(result))
        end subroutine large_chain
    end subroutine size_ranges

    ! ------------------------------------------------------------------ 3

    !> Output that cannot be written is a failure (exit 1, the reason on standard error):
    !! --output /dev/full, standard output on /dev/full or closed, a file-size limit
    !! (ulimit -f; on a full disk write(2) fails the same way), tables --csv on a full
    !! device, help text that cannot be written.
    subroutine unwritable_output(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(command_result_t) :: result
        character(len=:), allocatable :: path
        call expect(error, words("simulate", "--steps", "20", "--output", "/dev/full"), &
            exit_failure, [character(len=40) :: "/dev/full", "No space left on device"])
        if (allocated(error)) return
        call shell_with_exe("EXE simulate --steps 20 > /dev/full", result)
        call check(error, result%exit_code == exit_failure .and. clean(result) .and. &
            any_line_contains(result%err, "cannot write standard output"), &
            "simulate > /dev/full: exit " // int_str(result%exit_code) // ": " // &
            first_error(result))
        call shell_with_exe("EXE simulate --steps 20 >&-", result)
        call check(error, result%exit_code == exit_failure .and. clean(result) .and. &
            any_line_contains(result%err, "cannot write standard output"), &
            "simulate with standard output closed: exit " // int_str(result%exit_code))
        call shell_with_exe("EXE tables --quick --Mmax 1 --Nmax 1 > /dev/full", result)
        call check(error, result%exit_code == exit_failure .and. clean(result) .and. &
            any_line_contains(result%err, "No space left on device"), &
            "tables > /dev/full: exit " // int_str(result%exit_code))
        call shell_with_exe("EXE --help > /dev/full", result)
        call check(error, result%exit_code == exit_failure .and. clean(result), &
            "--help > /dev/full: exit " // int_str(result%exit_code))
        ! A file-size limit of 8 KiB: the CSV of 400 steps does not fit.
        path = scratch_path("limited.csv")
        call shell_with_exe("ulimit -f 8 && EXE simulate --steps 400 --output " // &
            shell_quote(path), result)
        call check(error, result%exit_code == exit_failure .and. clean(result) .and. &
            any_line_contains(result%err, "File too large"), "a file-size limit: exit " // &
            int_str(result%exit_code) // ": " // first_error(result))
        ! The rows reported are those that reached the file (complete lines less the header).
        call shell_with_exe("ulimit -f 8 && EXE simulate --steps 400 --output " // &
            shell_quote(path) // " 2> " // shell_quote(path // ".err") // " >/dev/null; " // &
            "rows=$(( $(wc -l < " // shell_quote(path) // ") - 1 )); grep -c " // &
            """; $rows complete rows reached"" " // shell_quote(path // ".err"), result)
        call check(error, size(result%out) == 1, "a file-size limit: no output")
        if (size(result%out) == 1) call check(error, result%out(1)%text == "1", &
            "a file-size limit: the rows in the file are reported: " // first_error(result))
        ! 2 blocks: 1 KiB in sh's units (LLVM's OpenMP runtime needs 1 KiB of shared memory
        ! file to start), 2 KiB in bash's; table2.csv has 2150 bytes.
        call shell_with_exe("ulimit -f 2 && EXE tables --quick --Mmax 1 --Nmax 1 --csv " // &
            shell_quote(scratch_path("limited_tables")), result)
        call check(error, result%exit_code == exit_failure .and. clean(result) .and. &
            any_line_contains(result%err, "File too large"), "tables --csv, size limit: exit " &
            // int_str(result%exit_code) // ": " // first_error(result))
    end subroutine unwritable_output

    !> The files of `ensemble`, `figures` and `bench` that cannot be written (a link to
    !! /dev/full, a file-size limit) fail the command with exit 1 and the file's name:
    !! the ensemble's results, timing log and samples (no row for the trajectory whose
    !! samples were lost, and --resume completes the run once the disk has room), each kind
    !! of figure file (the library's trajectory writer and the tool's own), and the
    !! bench's CSV, reference, summary and performance files.
    subroutine unwritable_files(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(command_result_t) :: result
        type(text_line_t), allocatable :: lines(:)
        character(len=:), allocatable :: dir, run
        character(len=24), parameter :: figure_files(4) = [character(len=24) :: &
            "fig1_pendulum.csv", "fig5_constraints.csv", "long_run.csv", "convergence.csv"]
        character(len=12), parameter :: figure_names(4) = [character(len=12) :: "fig1", &
            "fig5", "long", "convergence"]
        integer :: k, ios
        dir = absolute(scratch_path("unwritable"))
        call run_shell("rm -rf " // shell_quote(dir) // " && mkdir -p " // shell_quote(dir // &
            "/samples") // " && ln -s /dev/full " // shell_quote(dir // "/full"), result)
        run = "EXE ensemble --system linkage --perturb 3 --T 1 --quiet --output "
        ! Timing log on a full device.
        call shell_with_exe(run // shell_quote(dir // "/a.csv") // " --timing /dev/full", &
                            result)
        call check(error, result%exit_code == exit_failure .and. clean(result) .and. &
            any_line_contains(result%err, "timing log") .and. &
            any_line_contains(result%err, "'/dev/full'"), "ensemble --timing /dev/full: " // &
            "exit " // int_str(result%exit_code) // ": " // first_error(result))
        ! Results beyond a file-size limit of 1 or 2 KiB (sh's or bash's blocks): 8 rows of
        ! about 700 bytes do not fit.
        call shell_with_exe("ulimit -f 2 && " // run // shell_quote(dir // "/b.csv") // &
            " --perturb 8", result)
        call check(error, result%exit_code == exit_failure .and. clean(result) .and. &
            any_line_contains(result%err, "writing the results failed") .and. &
            any_line_contains(result%err, dir // "/b.csv"), "ensemble results beyond a " // &
            "file-size limit: exit " // int_str(result%exit_code) // ": " // first_error(result))
        ! Samples of trajectory 2 going to a full device: no row for it; --resume completes.
        call run_shell("ln -s /dev/full " // shell_quote(dir // "/samples/2.csv.part"), result)
        call shell_with_exe(run // shell_quote(dir // "/c.csv") // " --samples " // &
            shell_quote(dir // "/samples") // " --threads 1", result)
        call check(error, result%exit_code == exit_failure .and. clean(result) .and. &
            any_line_contains(result%err, "trajectory 2: storing the samples"), &
            "ensemble samples to a full device: exit " // int_str(result%exit_code) // ": " // &
            first_error(result))
        call read_lines(dir // "/c.csv", lines, ios)
        call check(error, ios == 0 .and. .not. any_prefix(lines, "2,"), "no row for the " // &
            "trajectory whose samples were lost")
        call run_shell("rm " // shell_quote(dir // "/samples/2.csv.part"), result)
        call shell_with_exe(run // shell_quote(dir // "/c.csv") // " --samples " // &
            shell_quote(dir // "/samples") // " --resume", result)
        call read_lines(dir // "/c.csv", lines, ios)
        call check(error, result%exit_code == 0 .and. file_exists(dir // "/samples/2.csv") &
            .and. any_prefix(lines, "2,"), "--resume completes the run: exit " // &
            int_str(result%exit_code) // ": " // first_error(result))
        ! Resuming a complete run whose timing log is gone starts a new log.
        call run_shell("rm " // shell_quote(dir // "/c.timing.csv"), result)
        call shell_with_exe(run // shell_quote(dir // "/c.csv") // " --samples " // &
            shell_quote(dir // "/samples") // " --resume", result)
        call check(error, result%exit_code == 0 .and. file_exists(dir // "/c.timing.csv"), &
            "--resume without a timing log: exit " // int_str(result%exit_code) // ": " // &
            first_error(result))
        if (allocated(error)) return
        ! Each kind of figure file on a full device.
        do k = 1, size(figure_files)
            call run_shell("rm -rf " // shell_quote(dir // "/figures") // " && mkdir " // &
                shell_quote(dir // "/figures") // " && ln -s /dev/full " // &
                shell_quote(dir // "/figures/" // trim(figure_files(k))), result)
            call shell_with_exe("EXE figures --quick --long-steps 200 --figure " // &
                trim(figure_names(k)) // " --out " // shell_quote(dir // "/figures"), result)
            call check(error, result%exit_code == exit_failure .and. clean(result) .and. &
                any_line_contains(result%err, trim(figure_files(k))), "figures " // &
                trim(figure_names(k)) // " to a full device: exit " // &
                int_str(result%exit_code) // ": " // first_error(result))
        end do
        if (allocated(error)) return
        ! The bench's files: summary.md and performance.md (--summarize), scaling.csv,
        ! long.csv and reference.csv on a full device.
        call run_shell("rm -rf " // shell_quote(dir // "/bench") // " && mkdir " // &
            shell_quote(dir // "/bench"), result)
        call write_lines(dir // "/bench/bench.csv", [character(len=400) :: &
            "system,method,precision,M,N,G,order,h,steps,error,energy_error," // &
            "constraint_residual,seconds,seconds_per_step,newton_iterations," // &
            "residual_evaluations,gradient_evaluations,hessian_evaluations," // &
            "lu_factorizations,status,difference_from_plain,tolerance,compile_seconds", &
            "pendulum,holosym,real128,2,1,3,4,1.25E-1,80,1.0E-9,1.0E-10,1.0E-33,1.0E-2," // &
            "1.25E-4,400,500,600,70,80,0,0,0,0"])
        call bench_fails("summary.md", "bench --summarize " // shell_quote(dir // "/bench"))
        call bench_fails("performance.md", "bench --summarize " // shell_quote(dir // "/bench"))
        call bench_fails("scaling.csv", "bench --scaling --quick --out " // &
            shell_quote(dir // "/bench"))
        call bench_fails("reference.csv", "bench --systems planar --Mmax 1 --order 2 " // &
            "--no-per-step --budget 0.01 --out " // shell_quote(dir // "/bench"))
        if (.not. wp_is_double) call bench_fails("long.csv", "bench --long --quick --out " // &
            shell_quote(dir // "/bench"))
    contains
        logical function any_prefix(rows, prefix)
            type(text_line_t), intent(in) :: rows(:)
            character(len=*), intent(in) :: prefix
            integer :: r
            any_prefix = .false.
            do r = 1, size(rows)
                if (index(rows(r)%text, prefix) == 1) any_prefix = .true.
            end do
        end function any_prefix
        !> `holosym ARGS` with DIR/bench/NAME a link to /dev/full fails naming NAME.
        subroutine bench_fails(name, arguments)
            character(len=*), intent(in) :: name, arguments
            character(len=:), allocatable :: link
            link = dir // "/bench/" // name
            if (wp_is_double .and. name == "scaling.csv") link = dir // "/bench/scaling64.csv"
            call run_shell("ln -sf /dev/full " // shell_quote(link), result)
            call shell_with_exe("EXE " // arguments, result)
            call check(error, result%exit_code == exit_failure .and. clean(result) .and. &
                any_line_contains(result%err, link) .and. &
                any_line_contains(result%err, "No space left on device"), "bench with " // &
                name // " on a full device: exit " // int_str(result%exit_code) // ": " // &
                first_error(result))
            call run_shell("rm -f " // shell_quote(link), result)
        end subroutine bench_fails
    end subroutine unwritable_files

    !> Devices and binary files given as input (/dev/zero, /dev/full, a link to them) are
    !! refused at once as not text, never read forever: bench --reference and
    !! --summarize, ensemble --states and --resume of a results file.
    subroutine device_inputs(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(command_result_t) :: result
        character(len=:), allocatable :: dir
        dir = absolute(scratch_path("devices"))
        call run_shell("rm -rf " // shell_quote(dir) // " && mkdir -p " // shell_quote(dir) // &
            " && ln -s /dev/zero " // shell_quote(dir // "/bench.csv"), result)
        call expect_timed("EXE bench --reference /dev/zero --systems planar --out " // &
            shell_quote(dir // "/out"), "not text")
        call expect_timed("EXE bench --summarize " // shell_quote(dir), "not text")
        call expect_timed("EXE ensemble --states /dev/zero --output " // &
            shell_quote(dir // "/e.csv"), "not text")
        call expect_timed("EXE ensemble --perturb 2 --output /dev/full --resume", "not text")
    contains
        subroutine expect_timed(line, text)
            character(len=*), intent(in) :: line, text
            call shell_with_exe("timeout 20 " // line, result)
            call check(error, result%exit_code == exit_failure .and. clean(result) .and. &
                any_line_contains(result%err, text), line // ": exit " // &
                int_str(result%exit_code) // " (124: still reading after 20 s): " // &
                first_error(result))
        end subroutine expect_timed
    end subroutine device_inputs

    ! ------------------------------------------------------------------ 4

    !> Step counts T/h that overflow or round to zero are usage errors, in tables and in
    !! simulate.
    subroutine step_counts(error)
        type(test_error_t), allocatable, intent(out) :: error
        character(len=:), allocatable :: big, small
        call expect(error, words("tables", "--T", "1e30"), exit_usage, &
            [character(len=40) :: "T/h is more than"])
        call expect(error, words("tables", "--T", "1e-30"), exit_usage, &
            [character(len=40) :: "rounds to 0 steps"])
        call expect(error, words("tables", "--T", "1e4900/1e-100"), exit_usage, &
            [character(len=40) :: "out of range"])
        call expect(error, words("tables", "--T", "1e-100"), exit_usage, &
            [character(len=40) :: "rounds to 0 steps"])
        call expect(error, words("tables", "--T", "1e7", "--h", "1,1e-300"), exit_usage, &
            [character(len=40) :: "T/h is more than"])
        call expect(error, words("simulate", "--T", "1e-30"), exit_usage, &
            [character(len=40) :: "rounds to 0 steps"])
        ! The largest magnitudes the parser accepts (1e4930 in real128, 1e306 in real64).
        big = "1e" // int_str(range(1.0_wp) - 1)
        small = "1e-" // int_str(range(1.0_wp) - 1)
        call expect(error, words("simulate", "--T", big, "--h", small), exit_usage, &
            [character(len=40) :: "T/h is more than"])
        call expect(error, words("simulate", "--h", big, "--steps", "1000"), exit_usage, &
            [character(len=40) :: "exceeds the largest number"])
    end subroutine step_counts

    ! ------------------------------------------------------------------ 5

    !> `tables --csv DIR` and `bench --out DIR` create DIR (and its parents) literally,
    !! without a shell: a name with quotes and a command creates a directory of that name,
    !! and the command is not run.
    subroutine no_shell(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(command_result_t) :: result
        character(len=:), allocatable :: base, dir
        base = absolute(scratch_path("shell"))
        call run_shell("rm -rf " // shell_quote(base) // " && mkdir -p " // shell_quote(base), &
                       result)
        dir = base // "/a b/x'; touch PWNED; echo '"
        call shell_with_exe("cd " // shell_quote(base) // " && EXE tables --quick --Mmax 1 " // &
            "--Nmax 0 --h 1/2,1/4 --T 1 --csv " // shell_quote(dir), result)
        call check(error, result%exit_code == 0, "tables --csv with quotes: exit " // &
            int_str(result%exit_code) // ": " // first_error(result))
        call check(error, file_exists(dir // "/table1.csv"), "the directory of that name holds " &
            // "table1.csv")
        call check(error, .not. file_exists(base // "/PWNED"), "a shell ran the name")
        dir = base // "/$(touch PWNED2)/`touch PWNED3`"
        call shell_with_exe("cd " // shell_quote(base) // " && EXE bench --out " // &
            shell_quote(dir) // " --reference " // shell_quote(base // "/none.csv") // &
            " --systems planar --Mmax 1 --order 2 --no-per-step", result)
        call check(error, result%exit_code == exit_failure, "bench --out with $(...): exit " // &
            int_str(result%exit_code) // ": " // first_error(result))
        call check(error, .not. (file_exists(base // "/PWNED2") .or. &
            file_exists(base // "/PWNED3")), "a shell ran the --out name")
        call check(error, file_exists(dir), "bench --out created the directory literally")
        call shell_with_exe("EXE tables --quick --Mmax 1 --Nmax 0 --csv /dev/null/x", result)
        call check(error, result%exit_code == exit_failure .and. clean(result) .and. &
            any_line_contains(result%err, "cannot create directory"), "--csv under a file: " &
            // "exit " // int_str(result%exit_code))
    end subroutine no_shell

    !> Paths with quotes, semicolons, `$(...)` and backquotes are used literally by
    !! `ensemble --output/--samples`, `figures --out`, `bench --out` and `bench --heyoka`:
    !! the directories and files get those names, heyoka's Python (here a script that
    !! records its arguments) receives each argument as given, and nothing the names hold
    !! is run.
    subroutine no_shell_anywhere(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(command_result_t) :: result
        type(text_line_t), allocatable :: lines(:)
        character(len=:), allocatable :: base, dir, python, reference
        character(len=*), parameter :: nasty = "/q'; touch PWNED; echo '/$(touch PWNED2)" // &
            "/`touch PWNED3`;touch PWNED4"
        integer :: ios, k
        logical :: found_out, found_reference
        base = absolute(scratch_path("no_shell"))
        call run_shell("rm -rf " // shell_quote(base) // " && mkdir -p " // shell_quote(base), &
                       result)
        dir = base // nasty
        ! ensemble: results, timing log and samples under the nasty directory.
        call run_shell("mkdir -p " // shell_quote(dir), result)
        call shell_with_exe("cd " // shell_quote(base) // " && EXE ensemble --system planar " &
            // "--perturb 2 --T 1 --quiet --output " // shell_quote(dir // "/r.csv") // &
            " --samples " // shell_quote(dir // "/samples x"), result)
        call check(error, result%exit_code == 0, "ensemble with a nasty path: exit " // &
            int_str(result%exit_code) // ": " // first_error(result))
        call check(error, file_exists(dir // "/r.csv") .and. file_exists(dir // &
            "/r.timing.csv") .and. file_exists(dir // "/samples x/2.csv"), &
            "ensemble wrote its files under the literal names")
        ! figures: a CSV of the library's trajectory writer and one of the tool's own.
        call shell_with_exe("cd " // shell_quote(base) // " && EXE figures --quick " // &
            "--figure fig1,fig5 --out " // shell_quote(dir // "/figures"), result)
        call check(error, result%exit_code == 0, "figures with a nasty path: exit " // &
            int_str(result%exit_code) // ": " // first_error(result))
        call check(error, file_exists(dir // "/figures/fig1_pendulum.csv") .and. &
            file_exists(dir // "/figures/fig5_constraints.csv"), "figures wrote under the " // &
            "literal name")
        ! bench --heyoka: a "Python" with a nasty name that records its arguments and fails.
        python = base // "/py'; touch PWNED5; echo '"
        call write_lines(python, [character(len=200) :: "#!/bin/sh", &
            "printf '%s\n' ""$@"" > " // shell_quote(base // "/arguments.txt"), "exit 3"])
        call run_shell("chmod +x " // shell_quote(python), result)
        reference = base // "/ref; $(touch PWNED6).csv"
        call write_lines(reference, [character(len=80) :: &
            "planar,q0,1,8.41470984807896506652502321630298954E-0001", &
            "planar,q0,2,-5.40302305868139717400936607442976558E-0001", &
            "planar,p0,1,0", "planar,p0,2,0", "planar,q,1,8.4E-1", "planar,q,2,-5.4E-1", &
            "planar,p,1,0.0E+0", "planar,p,2,0.0E+0"])
        call shell_with_exe("cd " // shell_quote(base) // " && EXE bench --out " // &
            shell_quote(dir // "/bench") // " --heyoka " // shell_quote(python) // &
            " --reference " // shell_quote(reference) // " --systems planar --Mmax 1 " // &
            "--order 2 --no-per-step --budget 0.01", result)
        call check(error, result%exit_code == exit_failure .and. clean(result) .and. &
            any_line_contains(result%err, "the heyoka sweep failed (exit status 3)"), &
            "bench --heyoka with a failing script: exit " // int_str(result%exit_code) // &
            ": " // first_error(result))
        call read_lines(base // "/arguments.txt", lines, ios)
        call check(error, ios == 0, "the script ran and recorded its arguments")
        if (allocated(error)) return
        found_out = .false.
        found_reference = .false.
        do k = 1, size(lines) - 1
            if (lines(k)%text == "--out") found_out = lines(k + 1)%text == dir // "/bench/" // &
                merge("heyoka64.csv.part", "heyoka.csv.part  ", wp_is_double)
            if (lines(k)%text == "--reference") found_reference = lines(k + 1)%text == reference
        end do
        call check(error, size(lines) > 0, "arguments recorded")
        if (allocated(error)) return
        call check(error, lines(1)%text == "tools/heyoka_bench.py" .and. found_out .and. &
            found_reference, "the script got --out and --reference as given: " // &
            lines(1)%text)
        ! bench --long --heyoka (real128 only): the long runs' script gets its paths too.
        if (.not. wp_is_double) then
            call run_shell("rm -f " // shell_quote(base // "/arguments.txt"), result)
            call shell_with_exe("cd " // shell_quote(base) // " && EXE bench --long " // &
                "--quick --out " // shell_quote(dir // "/long") // " --heyoka " // &
                shell_quote(python), result)
            call check(error, result%exit_code == exit_failure .and. clean(result) .and. &
                any_line_contains(result%err, "heyoka long runs failed (exit status 3)"), &
                "bench --long --heyoka with a failing script: exit " // &
                int_str(result%exit_code) // ": " // first_error(result))
            call read_lines(base // "/arguments.txt", lines, ios)
            found_out = .false.
            found_reference = .false.
            do k = 1, size(lines) - 1
                if (lines(k)%text == "--out") found_out = lines(k + 1)%text == dir // &
                    "/long/long.csv.heyoka"
                if (lines(k)%text == "--reference") found_reference = lines(k + 1)%text == &
                    dir // "/long/long_reference.csv"
            end do
            call check(error, ios == 0 .and. found_out .and. found_reference, &
                "the long runs' script got --out and --reference as given")
        end if
        do k = 1, 6
            call check(error, .not. (file_exists(base // "/PWNED" // trim(suffix(k))) .or. &
                file_exists("PWNED" // trim(suffix(k)))), "a shell ran a name (PWNED" // &
                trim(suffix(k)) // ")")
        end do
    contains
        pure function suffix(k) result(text)
            integer, intent(in) :: k
            character(len=1) :: text
            text = " "
            if (k > 1) write (text, '(i1)') k
        end function suffix
    end subroutine no_shell_anywhere

    ! ------------------------------------------------------------------ 6

    !> bench --reference rejects NaN, Inf, values out of range, an index given twice, one
    !! missing and malformed lines, naming the file and line (exit 1, before any sweep).
    subroutine reference_file(error)
        type(test_error_t), allocatable, intent(out) :: error
        character(len=*), parameter :: good(*) = [character(len=40) :: &
            "# reference", "planar,q,1,8.4E-1", "planar,q,2,-5.4E-1", "planar,p,1,0.0E+0", &
            "planar,p,2,0.0E+0"]
        character(len=*), parameter :: start(*) = [character(len=64) :: &
            "planar,q0,1,8.41470984807896506652502321630298954E-0001", &
            "planar,q0,2,-5.40302305868139717400936607442976558E-0001", &
            "planar,p0,1,0.0E+0", "planar,p0,2,0.0E+0"]
        call one([character(len=40) :: good(1:2), "planar,q,2,NaN", good(4:5)], &
            "not a finite number")
        call one([character(len=40) :: good(1:2), "planar,q,2,Inf", good(4:5)], &
            "not a finite number")
        call one([character(len=40) :: good(1:2), "planar,q,2,1e5000", good(4:5)], &
            "not a finite number")
        call one([character(len=40) :: good(1:2), "planar,q,1,0.5", good(4:5)], &
            "given twice")
        call one([character(len=40) :: good(1:2), good(4:5)], "lacks q(2)")
        call one([character(len=40) :: good, "planar,q,3,1.0"], "index must be in 1..2")
        call one([character(len=40) :: good, "planar,x,1,1.0"], "q or p")
        call one([character(len=40) :: good, "planar,q,1"], "4 comma-separated fields")
        ! The start q0, p0: optional as a pair, every index once, finite, the system's own.
        call one([character(len=64) :: good, start(1:3), "planar,q0,1,0.5"], "given twice")
        call one([character(len=64) :: good, start(1:3), "planar,p0,2,NaN"], &
            "not a finite number")
        call one([character(len=64) :: good, start(2:4), "planar,q0,1,0.5"], &
            "a reference of another start")
        call one([character(len=64) :: good, start(1:2)], "lacks p0(1)")
        call one([character(len=64) :: good, start(1:3)], "lacks p0(2)")
        call one([character(len=64) :: good, "planar,q0,1,8.4E-1" // achar(0)], "not text")
        ! heyoka starts from q0, p0: required with --heyoka.
        call one([character(len=40) :: good], "lacks q0(1) of system planar (--heyoka", &
                 "python3")

    contains

        subroutine one(lines, text, python)
            character(len=*), intent(in) :: lines(:)
            character(len=*), intent(in) :: text
            character(len=*), intent(in), optional :: python
            character(len=512) :: path, fragments(2)
            character(len=512), allocatable :: args(:)
            path = scratch_path("reference.csv")
            call write_lines(trim(path), lines)
            args = [character(len=512) :: "bench", "--out", scratch_path("bench_reference"), &
                "--reference", path, "--systems", "planar", "--no-per-step"]
            if (present(python)) args = [character(len=512) :: args, "--heyoka", python]
            fragments = [character(len=512) :: path, text]
            call expect(error, args, exit_failure, fragments)
        end subroutine one

    end subroutine reference_file

    ! ------------------------------------------------------------------ 10, 13

    !> A quotient that overflows or underflows, and numbers beyond the exponent range, are
    !! "out of range", not accepted as Inf or 0 and not "expects a number".
    subroutine numbers_out_of_range(error)
        type(test_error_t), allocatable, intent(out) :: error
        character(len=*), parameter :: values(*) = [character(len=24) :: "1e4900/1e-100", &
            "1e-4900/1e100", "1e5000", "-1e5000", "1e-5000", "1d99999", "1e999999999999", &
            "1e4932", "1/1e-4932"]
        integer :: k
        do k = 1, size(values)
            call expect(error, words("simulate", "--h", trim(values(k))), exit_usage, &
                [character(len=40) :: "--h", "out of range", "'" // trim(values(k)) // "'"], &
                [character(len=40) :: "expects a number", "Infinity"])
        end do
        call expect(error, words("simulate", "--h", "1/0"), exit_usage, &
            [character(len=40) :: "division by zero"])
    end subroutine numbers_out_of_range

    ! ------------------------------------------------------------------ 15

    !> An empty value, `--opt ""` or `--opt=`, is rejected like a missing one.
    subroutine empty_values(error)
        type(test_error_t), allocatable, intent(out) :: error
        call expect(error, words("simulate", "--output", ""), exit_usage, &
            [character(len=40) :: "--output needs a value"])
        call expect(error, words("simulate", "--output="), exit_usage, &
            [character(len=40) :: "--output needs a value"])
        call expect(error, words("tables", "--csv", ""), exit_usage, &
            [character(len=40) :: "--csv needs a value"])
        call expect(error, words("tables", "--csv="), exit_usage, &
            [character(len=40) :: "--csv needs a value"])
        call expect(error, words("bench", "--summarize", ""), exit_usage, &
            [character(len=40) :: "--summarize needs a value"])
        call expect(error, words("bench", "--out=", "--quick"), exit_usage, &
            [character(len=40) :: "--out needs a value"])
        call expect(error, words("bench", "--reference", ""), exit_usage, &
            [character(len=40) :: "--reference needs a value"])
        call expect(error, words("extremes", "--part="), exit_usage, &
            [character(len=40) :: "--part needs a value"])
    end subroutine empty_values

    ! ------------------------------------------------------------------ 16

    !> `extremes --part long --steps 1` runs one step (the growth ensemble needs two and is
    !! left out), within seconds.
    subroutine extremes_steps_bound(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(command_result_t) :: result
        call shell_with_exe("timeout 10 EXE extremes --part long --steps 1", result)
        call check(error, result%exit_code == 0, "extremes --part long --steps 1: exit " // &
            int_str(result%exit_code) // " (124: more than 10 s)")
        call check(error, any_line_contains(result%out, "1 of 1 steps"), "one step of the " // &
            "long run")
        call check(error, any_line_contains(result%out, "not run (--steps 1 < 2)"), &
            "the growth ensemble bounded")
        call shell_with_exe("timeout 10 EXE extremes --quick --part tiny,near-singular " // &
            "--steps 2", result)
        call check(error, result%exit_code == 0, "extremes --part tiny,near-singular " // &
            "--steps 2: exit " // int_str(result%exit_code))
        call check(error, any_line_contains(result%out, "2 steps per run") .and. &
            any_line_contains(result%out, "then 2 steps of h"), "tiny and near-singular runs " &
            // "of 2 steps")
    end subroutine extremes_steps_bound

    ! ------------------------------------------------------------------ 7, 9 (CLI)

    !> Steps below the resolution of the state and absurdly large steps end with exit 1 and
    !! the code that says so, through the tool. (h = 1e30 overflows nothing.)
    subroutine tiny_and_absurd_steps(error)
        type(test_error_t), allocatable, intent(out) :: error
        character(len=16) :: tiny_h
        tiny_h = "1e-14"
        if (epsilon(1.0_wp) > 1.0e-20_wp) tiny_h = "1e-9"
        call expect(error, words("simulate", "--h", trim(tiny_h), "--steps", "50"), &
            exit_failure, [character(len=40) :: "below the resolution", "use h >="], &
            [character(len=40) :: "N or G"])
        call expect(error, words("simulate", "--h", "1e30", "--steps", "1"), exit_failure, &
            [character(len=40) :: "step too large"], [character(len=40) :: "N or G"])
    end subroutine tiny_and_absurd_steps

    ! ------------------------------------------------------------------ randomized

    !> A few hundred argument vectors drawn (fixed seed) from pools of bad values, for every
    !! command: each run ends within `time_limit` seconds in success or a clean error (exit
    !! 1 or 2, a message on standard error, no runtime error, backtrace or signal), and no
    !! value reaches a shell.
    subroutine randomized_arguments(error)
        type(test_error_t), allocatable, intent(out) :: error
        character(len=*), parameter :: numbers(*) = [character(len=24) :: "", " ", "nan", &
            "NaN", "inf", "-Inf", "1e5000", "-1e5000", "1e-5000", "1e4900/1e-100", "1/0", &
            "0/0", "-1", "0", "-0", "2147483648", "-2147483649", "99999999999999999999", "1e", &
            "1.2.3", "x", "1/", "/1", "+", "--", "1,2", "0x10", "1d5000", "1e4932", "1e30", &
            "1e-30", "1e-300", "1e400", "1/1e-4932", "3e-4940", "4.5e", "1e999999999", "e5", &
            ".", "1 2", "-2147483648", "1e-14/1e300"]
        character(len=*), parameter :: orders(*) = [character(len=12) :: "2147483647", &
            "100000", "31", "65", "16", "13", "11", "-1", "1000"]
        character(len=*), parameter :: paths(*) = [character(len=48) :: "", "/dev/full", &
            "/nonexistent/dir/x", "x'; touch PWNED; echo '", "$(touch PWNED)", "/proc/x/y", &
            "`touch PWNED`", "/dev/null/x", "a b/../../../../../../dev/full"]
        character(len=*), parameter :: commands(*) = [character(len=10) :: "simulate", &
            "tables", "bench", "extremes", "ensemble", "figures", "help", "frob", ""]
        character(len=*), parameter :: systems(*) = [character(len=10) :: "chain", &
            "planar", "pendulum", "linkage", "double", "dumbbell", "magnetic", "generic"]
        ! Whole argument vectors that run (briefly) into a failure, or into a defect of the
        ! past: allocations sized by huge orders, overflowing step counts, unbounded parts.
        character(len=*), parameter :: runs(*) = [character(len=72) :: &
            "simulate --h 1e30 --steps 1", "simulate --h 1e-14 --steps 5", &
            "simulate --M 30 --N 30 --G 64 --steps 1", "simulate --h 50 --steps 2", &
            "simulate --output /dev/full --steps 3", "simulate --steps 0 --output /dev/full", &
            "simulate --T 0", "simulate --h 1e4930 --steps 1", "simulate --h 1e-4930 --steps 1", &
            "simulate --M 4 --N 2 --G 3 --steps 1", "simulate --system planar --h 1e-15 " // &
            "--steps 3", "simulate --output /proc/x --steps 1", &
            "simulate --output /nonexistent/dir/x --steps 1", &
            "simulate --system linkage --h 1e25 --steps 1", &
            "simulate --M 2147483647 --N 0 --G 1 --steps 1", "simulate --N 2147483647 --steps 1", &
            "simulate --G 100000 --steps 1", "simulate --M 100 --steps 1", &
            "tables --Mmax 2147483647 --Nmax 2147483647", "tables --Mmax 100000", &
            "tables --quick --Mmax 1 --Nmax 0 --h 1/2,1/4 --T 1 --csv /dev/full/x", &
            "tables --quick --Mmax 1 --Nmax 0 --h 1/2,1/4 --T 1 --csv /proc/x", &
            "extremes --part long --steps 1", "extremes --quick --part near-singular --steps 1", &
            "extremes --quick --part tiny --steps 2", "extremes --quick --part stiff --steps 1", &
            "bench --summarize /dev/full", "bench --summarize /nonexistent", &
            "bench --out /dev/full/x --systems planar --Mmax 1 --order 2", &
            "bench --out /proc/x --reference /nonexistent --systems planar", &
            "bench --scaling --quick --out /dev/full/x", "bench --long --quick --out /proc/x", &
            "bench --scaling-point 0", "bench --scaling-point 100001 --general", &
            "bench --heyoka /nonexistent/python --reference /dev/null --systems planar", &
            "bench --reference /dev/zero --systems planar", "bench --summarize /dev/zero", &
            "simulate --system chain --links 100001", "simulate --system chain --links 0", &
            "simulate --system chain --links 3 --steps 2", "simulate --links 3", &
            "simulate --system chain --links 2 --h 1e30 --steps 1", &
            "simulate --system chain --links 4 --plain --steps 1", &
            "ensemble --perturb 3 --T 1 --output /dev/full", &
            "ensemble --perturb 3 --T 1 --output /dev/full --resume", &
            "ensemble --states /dev/zero --output s.csv", &
            "ensemble --perturb 2 --T 1e4000 --h 1e-4000 --output z.csv", &
            "ensemble --perturb 2 --T 1e-30 --output z.csv", &
            "ensemble --perturb 2 --M 2147483647 --output z.csv", &
            "ensemble --perturb 2 --N 2147483647 --output z.csv", &
            "ensemble --perturb 2147483647 --output z.csv", "ensemble --perturb 2 --M 5 --G 3", &
            "ensemble --perturb 2 --scale 1e4000 --output z.csv", &
            "ensemble --perturb 2 --threads 100000 --output z.csv", &
            "ensemble --perturb 2 --T 1 --samples /dev/null/x --output w.csv", &
            "ensemble --perturb 2 --T 1 --output /proc/x/y.csv", &
            "ensemble --perturb 2 --T 1 --output t.csv --timing /dev/full", &
            "figures --quick --figure fig5 --out /dev/full/x", &
            "figures --quick --figure convergence --out /proc/x", &
            "figures --long-steps 2147483647 --figure long --out f", "figures --figure x", &
            "figures --out"]
        character(len=:), allocatable :: dir, line
        type(command_result_t) :: result
        integer(int64) :: state
        integer :: v, k, options, pick, start, finish, rate
        character(len=10) :: command

        dir = absolute(scratch_path("random"))
        call run_shell("rm -rf " // shell_quote(dir) // " && mkdir -p " // shell_quote(dir), &
                       result)
        state = 20260512_int64
        call system_clock(start, rate)
        do v = 1, random_vectors
            command = commands(1 + next(size(commands)))
            line = "cd " // shell_quote(dir) // " && timeout " // int_str(time_limit) // " EXE"
            if (len_trim(command) > 0) line = line // " " // trim(command)
            if (next(4) == 0) then
                ! A whole vector that runs into a failure (or a past defect).
                line = "cd " // shell_quote(dir) // " && timeout " // int_str(time_limit) // &
                    " EXE " // trim(runs(1 + next(size(runs))))
            else
                options = 1 + next(4)
                do k = 1, options
                    line = line // " " // option(command)
                end do
                line = line // closing_option(command)
            end if
            call shell_with_exe(line, result)
            call check(error, result%exit_code == 0 .or. result%exit_code == exit_failure .or. &
                result%exit_code == exit_usage, "vector " // int_str(v) // ": exit " // &
                int_str(result%exit_code) // ": " // line)
            call check(error, clean(result), "vector " // int_str(v) // ": not clean: " // &
                line // ": " // first_error(result))
            if (result%exit_code /= 0) call check(error, size(result%err) > 0, "vector " // &
                int_str(v) // ": failure without a message: " // line)
            call check(error, .not. file_exists(dir // "/PWNED"), "vector " // int_str(v) // &
                ": a shell ran a value: " // line)
            if (allocated(error)) return
        end do
        call system_clock(finish)
        call check(error, real(finish - start) / rate < 60, "the randomized test took " // &
            int_str((finish - start) / rate) // " s")

    contains

        !> Uniform in 0..count-1 (a 64-bit linear congruential generator).
        integer function next(count)
            integer, intent(in) :: count
            state = state * 6364136223846793005_int64 + 1442695040888963407_int64
            next = int(modulo(ishft(state, -33), int(count, int64)))
        end function next

        !> One option of `command` with a bad value, as two shell words or as --name=value.
        !! Every command's numeric options only draw values its parser rejects, so no vector
        !! starts a long run.
        function option(command) result(text)
            character(len=*), intent(in) :: command
            character(len=:), allocatable :: text
            character(len=:), allocatable :: name, value
            logical :: path_option
            path_option = .false.
            select case (command)
            case ("simulate")
                name = pick_name([character(len=12) :: "--M", "--N", "--G", "--h", "--T", &
                    "--steps", "--every", "--system", "--output", "--frob", "--links", &
                    "--plain"])
                path_option = name == "--output"
            case ("tables")
                name = pick_name([character(len=12) :: "--T", "--h", "--Mmax", "--Nmax", &
                    "--system", "--csv", "--T"])
                path_option = name == "--csv"
            case ("bench")
                name = pick_name([character(len=15) :: "--Mmax", "--order", "--budget", &
                    "--systems", "--out", "--reference", "--summarize", "--Mmax", &
                    "--scaling", "--long", "--quick", "--heyoka", "--scaling-point", &
                    "--general", "--no-per-step"])
                path_option = any(name == [character(len=12) :: "--out", "--reference", &
                    "--summarize", "--heyoka"])
            case ("extremes")
                name = pick_name([character(len=12) :: "--steps", "--max-order", "--part", &
                    "--steps"])
            case ("ensemble")
                name = pick_name([character(len=12) :: "--system", "--M", "--N", "--G", &
                    "--h", "--T", "--states", "--perturb", "--scale", "--seed", "--output", &
                    "--timing", "--samples", "--every", "--threads", "--project", "--resume", &
                    "--quiet"])
                path_option = any(name == [character(len=12) :: "--states", "--output", &
                    "--timing", "--samples"])
            case ("figures")
                name = pick_name([character(len=12) :: "--out", "--figure", "--long-steps", &
                    "--quick", "--out"])
                path_option = name == "--out"
            case default
                name = pick_name([character(len=12) :: "--help", "-h", "--x", "simulate", &
                    "--steps"])
            end select
            if (path_option) then
                value = trim(paths(1 + next(size(paths))))
            else if (name == "--system" .and. next(2) == 0) then
                value = trim(systems(1 + next(size(systems))))
            else if (any(name == [character(len=12) :: "--M", "--N", "--G", "--Mmax", &
                     "--Nmax", "--max-order", "--order"]) .and. next(2) == 0) then
                value = trim(orders(1 + next(size(orders))))
            else
                value = trim(numbers(1 + next(size(numbers))))
            end if
            select case (next(6))
            case (0, 1, 2)
                text = name // " " // shell_quote(value)
            case (3, 4)
                text = name // "=" // shell_quote(value)
            case default
                text = name
            end select
            ! Valid values around bad paths, so that the commands run into them (briefly).
            if (path_option) then
                select case (command)
                case ("simulate")
                    text = text // " --steps 3"
                case ("tables")
                    text = text // " --quick --Mmax 1 --Nmax 0 --h 1/2,1/4 --T 1"
                end select
            end if
        end function option

        !> An option the parser of `command` always rejects (after the drawn ones): no
        !! vector of tables, bench or extremes starts a long run.
        function closing_option(command) result(text)
            character(len=*), intent(in) :: command
            character(len=:), allocatable :: text
            select case (command)
            case ("tables")
                text = " --Mmax 0"
            case ("bench")
                text = " --order 1"
            case ("extremes")
                text = " --max-order 0"
            case ("ensemble")
                text = " --threads 0"
            case ("figures")
                text = " --long-steps 1"
            case default
                text = ""
            end select
        end function closing_option

        function pick_name(names) result(name)
            character(len=*), intent(in) :: names(:)
            character(len=:), allocatable :: name
            name = trim(names(1 + next(size(names))))
        end function pick_name

    end subroutine randomized_arguments

end module test_cli_hardening
