!> Files of an ensemble run: initial states read from CSV, results written as CSV rows the
!! moment each trajectory completes, a timing log, and sampled states in one file per
!! trajectory.
!!
!! Nothing lost: `ensemble_csv_sink` appends each result row and closes the file, so a
!! killed run keeps every completed row (a row cut short by the kill is dropped when the
!! run is resumed). Opening an existing results file for a new run is refused; `resume` keeps its
!! complete rows and marks their trajectories to skip. When the run has every row, `finish`
!! rewrites the file with the rows in ascending id order (to a temporary file, then renamed
!! over it): the same bytes whatever the order of completion, the number of threads or
!! ranks, and however often the run was interrupted. CPU and wall seconds go to the timing
!! log, never to the results, which are reproducible byte for byte.
!!
!! Results file: a first line `# ` followed by the caller's description of the run (a
!! resumed run must have the same), the header
!! `id,code,steps,steps_done,q1..qn,p1..pn,max_energy_error,max_constraint_residual,`
!! `max_velocity_residual,newton_iterations,message`, then one row per trajectory; reals
!! with 36 significant digits (exact in real128), the message in double quotes.
!!
!! Nothing written in vain: every file is written through the C library's streams
!! (`holosym_text_file`; Fortran units report neither a full disk nor a full device in
!! gfortran 12, and stop the program in LLVM flang), and each write closes its file, so a
!! write that does not reach the file stops the run with HOLOSYM_INVALID_ARGUMENT. Files
!! read (states, a results file to resume) must be text: a control byte or a line beyond
!! `max_text_line_length` (holosym_text_file) is refused, so that a device such as
!! /dev/zero cannot make the reader loop.
module holosym_ensemble_files
    use, intrinsic :: iso_fortran_env, only: int64
    use, intrinsic :: iso_c_binding, only: c_int, c_char, c_null_char
    use holosym_kinds, only: wp
    use holosym_decimal, only: read_decimal, number_ok
    use holosym_status_codes, only: holosym_status_t, set_status, int_str, real_str, &
        is_status_code, append_numbered, HOLOSYM_SUCCESS, HOLOSYM_INVALID_ARGUMENT
    use holosym_ensemble, only: ensemble_states_t, ensemble_result_t, ensemble_sink, &
        sorted_order, samples_failure
    use holosym_text_file, only: text_file_t, text_line_t, file_lock_t, read_text_lines, &
        error_text, printable
    implicit none
    private

    public :: read_ensemble_states, ensemble_csv_sink, result_header, result_row, &
        samples_header, parse_csv_fields, seconds_text

    !> Format of a real field: 36 significant digits round-trip a real128 exactly.
    character(len=*), parameter :: real_format = '(es44.35e4)'
    !> Longest integer accepted in a CSV field (digits of huge(1_int64)).
    integer, parameter :: max_integer_digits = 19
    !> Ids are integers from -max_id to max_id (at most 10 digits), in every file.
    integer, parameter, public :: max_id = huge(1)

    !> Writes the results file, the timing log and the samples of an ensemble run.
    type, extends(ensemble_sink) :: ensemble_csv_sink
        !> Unit for progress lines; negative for none.
        integer :: progress_unit = -1
        !> Seconds between progress lines (the last line is always written).
        real(wp) :: progress_interval = 5
        !> Prefix of progress lines.
        character(len=:), allocatable :: label
        !> Directory of the sample files `<id>.csv` ("" for none).
        character(len=:), allocatable :: samples_dir
        character(len=:), allocatable, private :: path, timing_path, description
        integer, private :: n = 0
        integer, private :: to_do = 0
        integer, private :: done = 0
        integer, private :: failed = 0
        integer, private :: rows = 0
        integer, private :: expected_rows = 0
        integer(int64), private :: clock_start = 0
        integer(int64), private :: clock_rate = 1
        integer(int64), private :: clock_last = 0
        character(len=:), allocatable, private :: io_message
        type(file_lock_t), private :: lock
    contains
        !> Create the results file (refused if it exists) or, to resume, reopen it.
        procedure :: open => sink_open
        !> Write a completed trajectory's row (and timing), checked; report progress.
        procedure :: completed => sink_completed
        !> Write a trajectory's samples to samples_dir/<id>.csv (via a temporary file).
        procedure :: store_samples => sink_store_samples
        !> Close the files; with every row present, sort the rows by id.
        procedure :: finish => sink_finish
        !> Trajectories that failed among those written in this run.
        procedure :: failures => sink_failures
    end type ensemble_csv_sink

    interface
        integer(c_int) function c_rename(old, new) bind(C, name="rename")
            import :: c_int, c_char
            character(kind=c_char), intent(in) :: old(*)
            character(kind=c_char), intent(in) :: new(*)
        end function c_rename

        integer(c_int) function c_remove(path) bind(C, name="remove")
            import :: c_int, c_char
            character(kind=c_char), intent(in) :: path(*)
        end function c_remove
    end interface

contains

    !> Read initial states from a CSV file with rows `id,q1..qn,p1..pn[,h][,T]`: an optional
    !! header line naming exactly these columns (`id,q1,...,pn,h,T`), blank lines and lines
    !! starting with '#' ignored. Without a header the first row's field count says whether
    !! h and T are there (2n + 1, 2n + 2 or 2n + 3 fields). Every row must have that count,
    !! an integer id, finite numbers and an id of its own. Fails with
    !! HOLOSYM_INVALID_ARGUMENT and a message "FILE:LINE: what"; `states` is then unchanged.
    subroutine read_ensemble_states(path, n, states, status)
        character(len=*), intent(in) :: path               !! the CSV file
        integer, intent(in) :: n                           !! coordinates of the system
        type(ensemble_states_t), intent(inout) :: states   !! the states read
        type(holosym_status_t), intent(out), optional :: status !! outcome
        type(ensemble_states_t) :: read
        type(text_line_t), allocatable :: lines(:)
        integer, allocatable :: line_of(:)
        character(len=:), allocatable :: message
        type(holosym_status_t) :: local
        integer :: ios, width

        call read_lines_of(path, lines, ios, message)
        if (ios /= 0) then
            call set_status(status, HOLOSYM_INVALID_ARGUMENT, "cannot read states file '" // &
                path // "': " // message)
            return
        end if
        call locate_state_rows(path, n, lines, line_of, width, local)
        if (local%ok()) call parse_state_rows(path, n, lines, line_of, width, read, local)
        if (local%ok()) call check_unique_ids(path, read%id, line_of, local)
        if (local%ok() .and. size(line_of) == 0) &
            call set_status(local, HOLOSYM_INVALID_ARGUMENT, path // ": no states")
        if (local%ok()) states = read
        call set_status(status, local%code, local%message)
    end subroutine read_ensemble_states

    !> The data rows of a states file: the line of each (blank lines, comments and the
    !! header skipped) and the field count every row must have, checked against the header
    !! or, without one, the first row. Fails with HOLOSYM_INVALID_ARGUMENT, "FILE:LINE: what".
    subroutine locate_state_rows(path, n, lines, line_of, width, status)
        character(len=*), intent(in) :: path            !! the file, for messages
        integer, intent(in) :: n                        !! coordinates of the system
        type(text_line_t), intent(in) :: lines(:)       !! the file's lines
        integer, allocatable, intent(out) :: line_of(:) !! line of each data row
        integer, intent(out) :: width                   !! fields of every row (0: no rows)
        type(holosym_status_t), intent(out) :: status   !! outcome
        type(text_line_t), allocatable :: fields(:)
        integer :: ios, i, rows
        logical :: header

        call set_status(status, HOLOSYM_SUCCESS, "")
        width = 0
        header = .false.
        rows = 0
        allocate (line_of(size(lines)))
        do i = 1, size(lines)
            if (ignorable(lines(i)%text)) cycle
            call parse_csv_fields(lines(i)%text, fields, ios)
            if (width == 0) then
                if (fields(1)%text == "id") then
                    header = .true.
                    width = size(fields)
                    if (.not. header_matches(fields, n)) then
                        call line_failure(status, path, i, "the header must be id,q1..q" // &
                            int_str(n) // ",p1..p" // int_str(n) // " and optionally h and " // &
                            "T; got '" // printable(lines(i)%text) // "'")
                        return
                    end if
                    cycle
                end if
                width = size(fields)
                if (width < 2 * n + 1 .or. width > 2 * n + 3) then
                    call line_failure(status, path, i, "expected 2n + 1 = " // &
                        int_str(2 * n + 1) // " fields (id,q1..q" // int_str(n) // ",p1..p" // &
                        int_str(n) // "), optionally followed by h and T; got " // int_str(width))
                    return
                end if
            end if
            if (size(fields) /= width) then
                call line_failure(status, path, i, "expected " // int_str(width) // &
                    " fields like the " // trim(merge("header   ", "first row", header)) // &
                    "; got " // int_str(size(fields)))
                return
            end if
            rows = rows + 1
            line_of(rows) = i
        end do
        line_of = line_of(:rows)
    end subroutine locate_state_rows

    !> Whether a states file's header names the columns id,q1..qn,p1..pn[,h][,T].
    logical function header_matches(names, n)
        type(text_line_t), intent(in) :: names(:) !! the header's fields
        integer, intent(in) :: n                  !! coordinates of the system
        integer :: c
        header_matches = size(names) >= 2 * n + 1 .and. size(names) <= 2 * n + 3
        if (.not. header_matches) return
        do c = 1, n
            header_matches = header_matches .and. names(c + 1)%text == "q" // int_str(c) &
                .and. names(c + n + 1)%text == "p" // int_str(c)
        end do
        if (size(names) >= 2 * n + 2) header_matches = header_matches .and. &
            names(2 * n + 2)%text == "h"
        if (size(names) >= 2 * n + 3) header_matches = header_matches .and. &
            names(2 * n + 3)%text == "T"
    end function header_matches

    !> The states of the data rows (`width` fields each): an integer id, finite q and p,
    !! h > 0 and T >= 0 when present. Fails with HOLOSYM_INVALID_ARGUMENT naming the line
    !! and the field.
    subroutine parse_state_rows(path, n, lines, line_of, width, read, status)
        character(len=*), intent(in) :: path          !! the file, for messages
        integer, intent(in) :: n                      !! coordinates of the system
        type(text_line_t), intent(in) :: lines(:)     !! the file's lines
        integer, intent(in) :: line_of(:)             !! line of each data row
        integer, intent(in) :: width                  !! fields of every row
        type(ensemble_states_t), intent(out) :: read  !! the states
        type(holosym_status_t), intent(out) :: status !! outcome
        type(text_line_t), allocatable :: fields(:)
        integer :: ios, i, j, k, rows

        call set_status(status, HOLOSYM_SUCCESS, "")
        rows = size(line_of)
        allocate (read%id(rows), read%q(n, rows), read%p(n, rows))
        if (width >= 2 * n + 2) allocate (read%step_size(rows))
        if (width >= 2 * n + 3) allocate (read%final_time(rows))
        do k = 1, rows
            i = line_of(k)
            call parse_csv_fields(lines(i)%text, fields, ios)
            if (.not. integer_field(fields(1)%text, read%id(k))) then
                call line_failure(status, path, i, "field 1 (id) must be an integer from " // &
                    int_str(-max_id) // " to " // int_str(max_id) // "; got '" // &
                    printable(fields(1)%text) // "'")
                return
            end if
            do j = 2, width
                if (j <= n + 1) then
                    if (.not. real_field(j, read%q(j - 1, k))) return
                else if (j <= 2 * n + 1) then
                    if (.not. real_field(j, read%p(j - n - 1, k))) return
                else if (j == 2 * n + 2) then
                    if (.not. real_field(j, read%step_size(k))) return
                    if (.not. read%step_size(k) > 0) then
                        call bound_failure("h", "> 0")
                        return
                    end if
                else
                    if (.not. real_field(j, read%final_time(k))) return
                    if (.not. read%final_time(k) >= 0) then
                        call bound_failure("T", ">= 0")
                        return
                    end if
                end if
            end do
        end do

    contains

        !> Field `column` of the current row as a finite real, or a failure naming it.
        logical function real_field(column, value) result(ok)
            integer, intent(in) :: column !! the field
            real(wp), intent(out) :: value !! its value
            ok = decimal_field(fields(column)%text, value)
            if (.not. ok) call line_failure(status, path, i, "field " // int_str(column) // &
                " must be a finite number; got '" // printable(fields(column)%text) // "'")
        end function real_field

        !> Field j of the current row (h or T) out of its range.
        subroutine bound_failure(name, bound)
            character(len=*), intent(in) :: name  !! the column's name
            character(len=*), intent(in) :: bound !! what it must be
            call line_failure(status, path, i, "field " // int_str(j) // " (" // name // &
                ") must be " // bound // "; got '" // printable(fields(j)%text) // "'")
        end subroutine bound_failure

    end subroutine parse_state_rows

    !> Every id of a states file its own: a duplicate fails with HOLOSYM_INVALID_ARGUMENT
    !! on the later of its lines, naming the earlier.
    subroutine check_unique_ids(path, ids, line_of, status)
        character(len=*), intent(in) :: path          !! the file, for messages
        integer, intent(in) :: ids(:)                 !! the ids, one per data row
        integer, intent(in) :: line_of(:)             !! line of each data row
        type(holosym_status_t), intent(out) :: status !! outcome
        integer, allocatable :: order(:)
        integer :: k
        call set_status(status, HOLOSYM_SUCCESS, "")
        order = sorted_order(ids)
        do k = 2, size(ids)
            if (ids(order(k)) == ids(order(k - 1))) then
                call line_failure(status, path, line_of(max(order(k), order(k - 1))), &
                    "duplicate id " // int_str(ids(order(k))) // " (also on line " // &
                    int_str(line_of(min(order(k), order(k - 1)))) // ")")
                return
            end if
        end do
    end subroutine check_unique_ids

    !> HOLOSYM_INVALID_ARGUMENT with the message "FILE:LINE: what".
    pure subroutine line_failure(status, path, line, what)
        type(holosym_status_t), intent(inout) :: status !! set
        character(len=*), intent(in) :: path            !! the file
        integer, intent(in) :: line                     !! the line
        character(len=*), intent(in) :: what            !! what is wrong
        call set_status(status, HOLOSYM_INVALID_ARGUMENT, path // ":" // int_str(line) // &
            ": " // what)
    end subroutine line_failure

    !> Blank lines and comments ('#' first) of a states file.
    pure logical function ignorable(line)
        character(len=*), intent(in) :: line
        integer :: first
        first = verify(line, " ")
        ignorable = first == 0
        if (.not. ignorable) ignorable = line(first:first) == "#"
    end function ignorable

    !> Split a CSV line at commas outside double quotes; a quoted field loses its quotes and
    !! "" inside it stands for one quote. Blanks around unquoted fields are removed. `ios`
    !! is 1 when a quote is not closed (a line cut short), else 0.
    subroutine parse_csv_fields(line, fields, ios)
        character(len=*), intent(in) :: line                    !! the line
        type(text_line_t), allocatable, intent(out) :: fields(:) !! its fields
        integer, intent(out) :: ios                             !! 0, or 1 for an open quote
        character(len=:), allocatable :: field
        logical :: quoted, was_quoted
        integer :: i
        allocate (fields(0))
        field = ""
        quoted = .false.
        was_quoted = .false.
        ios = 0
        i = 1
        do while (i <= len(line))
            if (quoted) then
                if (line(i:i) == '"') then
                    if (i < len(line)) then
                        if (line(i + 1:i + 1) == '"') then
                            field = field // '"'
                            i = i + 2
                            cycle
                        end if
                    end if
                    quoted = .false.
                else
                    field = field // line(i:i)
                end if
            else if (line(i:i) == '"' .and. len_trim(field) == 0) then
                quoted = .true.
                was_quoted = .true.
                field = ""
            else if (line(i:i) == ",") then
                call finish_field()
            else
                field = field // line(i:i)
            end if
            i = i + 1
        end do
        if (quoted) ios = 1
        call finish_field()
    contains
        subroutine finish_field()
            if (was_quoted) then
                fields = [fields, text_line_t(field)]
            else
                fields = [fields, text_line_t(trim(adjustl(field)))]
            end if
            field = ""
            was_quoted = .false.
        end subroutine finish_field
    end subroutine parse_csv_fields

    !> An id field: a decimal integer from -max_id to max_id (at most 10 digits).
    logical function integer_field(text, value) result(ok)
        character(len=*), intent(in) :: text
        integer, intent(out) :: value
        integer(int64) :: wide
        ok = integer_in(text, -int(max_id, int64), int(max_id, int64), wide)
        value = 0
        if (ok) value = int(wide)
    end function integer_field

    !> A decimal integer field (optional sign, digits only, at most 19 of them) from `low`
    !! to `high`.
    logical function integer_in(text, low, high, value) result(ok)
        character(len=*), intent(in) :: text
        integer(int64), intent(in) :: low, high
        integer(int64), intent(out) :: value
        integer :: first, ios
        value = 0
        first = 1
        if (len(text) >= 1) then
            if (text(1:1) == "+" .or. text(1:1) == "-") first = 2
        end if
        ok = len(text) >= first .and. len(text) - first + 1 <= max_integer_digits
        if (ok) ok = verify(text(first:), "0123456789") == 0
        if (.not. ok) return
        read (text, *, iostat=ios) value
        ok = ios == 0
        if (ok) ok = value >= low .and. value <= high
    end function integer_in

    !> A finite decimal number: [sign] digits [. digits] [(e|E|d|D) [sign] digits] with at
    !! least one mantissa digit and nothing else (so NaN and Inf are refused), and a
    !! magnitude in the range of every number holosym reads (`read_decimal`).
    logical function decimal_field(text, value) result(ok)
        character(len=*), intent(in) :: text
        real(wp), intent(out) :: value
        integer :: outcome
        call read_decimal(text, value, outcome)
        ok = outcome == number_ok
    end function decimal_field

    !> Append `separator` and a real as a CSV field (36 significant digits, no blanks) to
    !! `line`.
    subroutine append_real(line, separator, value)
        character(len=:), allocatable, intent(inout) :: line !! the text so far
        character(len=*), intent(in) :: separator            !! put before the field
        real(wp), intent(in) :: value                        !! the value
        character(len=48) :: buffer
        write (buffer, real_format) value
        line = line // separator // trim(adjustl(buffer))
    end subroutine append_real

    !> The header of the results file for n coordinates.
    pure function result_header(n) result(header)
        integer, intent(in) :: n !! number of coordinates
        character(len=:), allocatable :: header
        header = "id,code,steps,steps_done,"
        call append_numbered(header, "q", n, ",")
        header = header // ","
        call append_numbered(header, "p", n, ",")
        header = header // ",max_energy_error,max_constraint_residual,max_velocity_residual," &
            // "newton_iterations,message"
    end function result_header

    !> The results row of one trajectory (see the module header).
    function result_row(result) result(row)
        type(ensemble_result_t), intent(in) :: result !! the trajectory
        character(len=:), allocatable :: row
        character(len=24) :: iterations
        integer :: i
        row = int_str(result%id) // "," // int_str(result%code) // "," // &
            int_str(result%steps) // "," // int_str(result%steps_done)
        do i = 1, size(result%q)
            call append_real(row, ",", result%q(i))
        end do
        do i = 1, size(result%p)
            call append_real(row, ",", result%p(i))
        end do
        call append_real(row, ",", result%max_energy_error)
        call append_real(row, ",", result%max_constraint_residual)
        call append_real(row, ",", result%max_velocity_residual)
        write (iterations, '(i0)') result%newton_iterations
        row = row // "," // trim(iterations) // "," // quoted(result%message)
    end function result_row

    !> Text in double quotes, each quote doubled, control characters as blanks.
    pure function quoted(text) result(field)
        character(len=*), intent(in) :: text
        character(len=:), allocatable :: field
        integer :: i
        field = '"'
        do i = 1, len(text)
            if (text(i:i) == '"') then
                field = field // '""'
            else if (iachar(text(i:i)) < 32) then
                field = field // " "
            else
                field = field // text(i:i)
            end if
        end do
        field = field // '"'
    end function quoted

    !> The header of a samples file for n coordinates.
    pure function samples_header(n) result(header)
        integer, intent(in) :: n !! number of coordinates
        character(len=:), allocatable :: header
        integer :: i
        header = "t"
        do i = 1, n
            header = header // ",q" // int_str(i)
        end do
        do i = 1, n
            header = header // ",p" // int_str(i)
        end do
        header = header // ",energy_error,constraint_residual,velocity_residual"
    end function samples_header

    !> Write `lines` to the file `path` and close it through `text_file_t` (the C
    !! library's streams: a write that does not reach the file is seen, which Fortran
    !! units do not guarantee): `mode` "new" (the file must not exist), "replace" or
    !! "append" (created when missing). `message`: "" on success, else what failed,
    !! naming the file.
    subroutine write_checked(path, lines, mode, message)
        character(len=*), intent(in) :: path          !! the file
        type(text_line_t), intent(in) :: lines(:)      !! lines, without their ends
        character(len=*), intent(in) :: mode          !! "new", "replace" or "append"
        character(len=:), allocatable, intent(out) :: message !! "" or the failure
        type(text_file_t) :: file
        integer :: k
        message = ""
        if (.not. file%open(path, mode)) then
            message = file%failure
            return
        end if
        do k = 1, size(lines)
            call file%line(lines(k)%text)
        end do
        if (.not. file%close()) message = file%failure
    end subroutine write_checked

    !> Rename a file (POSIX rename: atomic within a file system).
    logical function rename_file(old, new) result(ok)
        character(len=*), intent(in) :: old, new
        ok = c_rename(old // c_null_char, new // c_null_char) == 0
    end function rename_file

    !> Create the results file `path` for a run of `ids` with n coordinates, or reopen it
    !! with `resume`, and hold an exclusive lock on it (flock) until `finish`, so that no
    !! other run (fresh or resumed, threads or MPI) writes it meanwhile. `description` (one
    !! line) describes the run; a resumed file must have been written with the same.
    !! `skip(k)` is true for the trajectories `ids(k)` that already have their row. The
    !! timing log `timing_path` ("" for none) is appended to. Fails with
    !! HOLOSYM_INVALID_ARGUMENT, changing no file (a results file this call created is
    !! removed again), when the results file exists without `resume`, is locked by another
    !! run, cannot be created (the system's reason), holds anything but valid complete rows
    !! of these ids written with this description (a row cut short at the end of the file
    !! is the trace of a killed run: it is cut off), or the timing log cannot be written.
    !! Lines may end in CR LF.
    subroutine sink_open(self, path, timing_path, description, n, ids, resume, skip, status)
        class(ensemble_csv_sink), intent(inout) :: self !! the sink
        character(len=*), intent(in) :: path        !! results file
        character(len=*), intent(in) :: timing_path !! timing log, "" for none
        character(len=*), intent(in) :: description !! one line describing the run
        integer, intent(in) :: n                    !! coordinates of the system
        integer, intent(in) :: ids(:)               !! ids of the trajectories
        logical, intent(in) :: resume               !! reopen an existing file
        logical, allocatable, intent(out) :: skip(:) !! trajectories with a row already
        type(holosym_status_t), intent(out) :: status !! outcome
        type(text_line_t), allocatable :: first_lines(:)
        character(len=:), allocatable :: message
        integer(int64) :: cut
        integer :: error, kept
        logical :: exists, held_elsewhere

        call set_status(status, HOLOSYM_SUCCESS, "")
        allocate (skip(size(ids)))
        skip = .false.
        if (.not. allocated(self%label)) self%label = ""
        if (.not. allocated(self%samples_dir)) self%samples_dir = ""
        if (index(description, new_line("a")) > 0) then
            call set_status(status, HOLOSYM_INVALID_ARGUMENT, "the description must be one line")
            return
        end if
        inquire (file=path, exist=exists)
        if (exists .and. .not. resume) then
            call set_status(status, HOLOSYM_INVALID_ARGUMENT, "results file '" // path // &
                "' exists; resume the run (--resume) or remove it (nothing was changed)")
            return
        end if
        call self%lock%acquire(path, .not. exists, error, held_elsewhere)
        if (held_elsewhere) then
            call set_status(status, HOLOSYM_INVALID_ARGUMENT, "results file '" // path // &
                "' is in use: another run holds its lock; wait for that run to end " // &
                "(nothing was changed)")
            return
        else if (error /= 0) then
            call set_status(status, HOLOSYM_INVALID_ARGUMENT, "cannot " // &
                trim(merge("open  ", "create", exists)) // " results file '" // path // &
                "': " // error_text(error))
            return
        end if
        self%path = path
        self%description = description
        self%n = n
        self%expected_rows = size(ids)
        kept = 0
        if (exists) then
            call resumed_rows(path, description, n, ids, skip, kept, cut, status)
            if (status%ok() .and. cut >= 0) then
                error = self%lock%truncate(cut)
                if (error /= 0) call set_status(status, HOLOSYM_INVALID_ARGUMENT, &
                    "cannot cut the last row of '" // path // "': " // error_text(error))
            end if
        else
            allocate (first_lines(2))
            first_lines(1)%text = "# " // description
            first_lines(2)%text = result_header(n)
            call write_checked(path, first_lines, "append", message)
            if (len(message) > 0) call set_status(status, HOLOSYM_INVALID_ARGUMENT, &
                "cannot write results file: " // message)
        end if
        if (status%ok()) call start_timing_log(timing_path, status)
        if (.not. status%ok()) then
            skip = .false.
            if (.not. exists) call remove_created(path)
            call self%lock%release()
            return
        end if
        self%rows = kept
        self%timing_path = timing_path
        if (cut >= 0 .and. exists .and. self%progress_unit >= 0) write (self%progress_unit, &
            '(a)') self%label // "dropped the last row of '" // path // "', cut short " // &
            "by the interrupted run"
        self%to_do = count(.not. skip)
        self%done = 0
        self%failed = 0
        self%io_message = ""
        call system_clock(self%clock_start, self%clock_rate)
        self%clock_last = self%clock_start
    end subroutine sink_open

    !> The timing log `path` with its header when it does not exist yet ("" for none).
    subroutine start_timing_log(path, status)
        character(len=*), intent(in) :: path
        type(holosym_status_t), intent(inout) :: status
        type(text_line_t) :: header(1)
        character(len=:), allocatable :: message
        logical :: exists
        if (len(path) == 0) return
        inquire (file=path, exist=exists)
        if (exists) return
        header(1)%text = "id,cpu_seconds,wall_seconds"
        call write_checked(path, header, "new", message)
        if (len(message) > 0) call set_status(status, HOLOSYM_INVALID_ARGUMENT, &
            "cannot write timing log: " // message)
    end subroutine start_timing_log

    !> Remove a file this run created (a failed start leaves nothing behind).
    subroutine remove_created(path)
        character(len=*), intent(in) :: path
        integer(c_int) :: outcome
        outcome = c_remove(path // c_null_char)
    end subroutine remove_created

    !> The rows of the results file `path` to resume: the first line must be
    !! "# description", the second the header, every other line a valid row (`row_problem`)
    !! of one of `ids`, at most one per id. `skip(k)`: ids(k) has its row; `kept` rows;
    !! `cut`: the length in bytes to cut the file to when its last row was cut short by a
    !! kill, else -1. A failure names the line and the field.
    subroutine resumed_rows(path, description, n, ids, skip, kept, cut, status)
        character(len=*), intent(in) :: path, description
        integer, intent(in) :: n, ids(:)
        logical, intent(inout) :: skip(:)
        integer, intent(out) :: kept
        integer(int64), intent(out) :: cut
        type(holosym_status_t), intent(inout) :: status
        type(text_line_t), allocatable :: lines(:), fields(:)
        integer(int64), allocatable :: ends(:)
        character(len=:), allocatable :: message, problem
        integer, allocatable :: order(:)
        integer :: ios, i, id, position

        kept = 0
        cut = -1
        call read_lines_of(path, lines, ios, message, ends)
        if (ios /= 0) then
            call fail("cannot read '" // path // "': " // message)
            return
        end if
        if (size(lines) < 2) then
            call fail("'" // path // "' has no header; it is not the results file of a " // &
                "run (nothing was changed)")
            return
        end if
        if (lines(1)%text /= "# " // description) then
            call fail("'" // path // "' was written by another run: " // &
                difference(lines(1)%text, "# " // description) // " (nothing was changed)")
            return
        end if
        if (lines(2)%text /= result_header(n)) then
            call fail("'" // path // "': line 2 is not the results header " // &
                "(nothing was changed)")
            return
        end if
        order = sorted_order(ids)
        do i = 3, size(lines)
            call parse_csv_fields(lines(i)%text, fields, ios)
            if (ios /= 0 .or. size(fields) /= 2 * n + 9) then
                if (i == size(lines)) then
                    cut = ends(i - 1)
                    exit
                end if
                call fail("'" // path // "':" // int_str(i) // ": not a complete " // &
                    "results row (nothing was changed)")
                return
            end if
            problem = row_problem(fields, n)
            if (len(problem) > 0) then
                call fail("'" // path // "':" // int_str(i) // ": " // problem // &
                    " (nothing was changed)")
                return
            end if
            if (.not. integer_field(fields(1)%text, id)) id = 0
            position = find_sorted(id)
            if (position == 0) then
                call fail("'" // path // "':" // int_str(i) // ": id " // int_str(id) // &
                    " is not among the trajectories of this run (nothing was changed)")
                return
            end if
            if (skip(position)) then
                call fail("'" // path // "':" // int_str(i) // ": a second row for id " // &
                    int_str(id) // " (nothing was changed)")
                return
            end if
            skip(position) = .true.
            kept = kept + 1
        end do

    contains

        subroutine fail(what)
            character(len=*), intent(in) :: what
            call set_status(status, HOLOSYM_INVALID_ARGUMENT, what)
        end subroutine fail

        !> Index k with ids(k) == key, 0 if none (binary search in `order`).
        integer function find_sorted(key) result(found)
            integer, intent(in) :: key
            integer :: low, high, middle
            found = 0
            low = 1
            high = size(order)
            do while (low <= high)
                middle = (low + high) / 2
                if (ids(order(middle)) == key) then
                    found = order(middle)
                    return
                else if (ids(order(middle)) < key) then
                    low = middle + 1
                else
                    high = middle - 1
                end if
            end do
        end function find_sorted

    end subroutine resumed_rows

    !> Two lines that differ, for a message: both quoted with non-printing characters
    !! visible, and the first character where they differ.
    function difference(found, wanted) result(text)
        character(len=*), intent(in) :: found, wanted
        character(len=:), allocatable :: text
        integer :: k
        k = 1
        do while (k <= min(len(found), len(wanted)))
            if (found(k:k) /= wanted(k:k)) exit
            k = k + 1
        end do
        text = "its first line is '" // printable(found) // "', this run's '" // &
            printable(wanted) // "' (they differ from character " // int_str(k) // ")"
    end function difference

    !> "" when the fields of a results row (2n + 9 of them) are valid, else what is wrong,
    !! naming the field: id an integer of at most 10 digits in -max_id..max_id; code one of
    !! the status codes (holosym_status_codes); steps and steps_done integers with
    !! 0 <= steps_done <= steps <= huge(1); the state finite numbers; the residuals and
    !! energy error numbers >= 0 (or the writer's NaN and Infinity); newton_iterations
    !! an integer in 0..huge(int64).
    function row_problem(fields, n) result(problem)
        type(text_line_t), intent(in) :: fields(:) !! the row's fields
        integer, intent(in) :: n                   !! coordinates
        character(len=:), allocatable :: problem
        type(text_line_t), allocatable :: names(:)
        integer(int64) :: value, steps
        real(wp) :: number
        integer :: ios, j
        logical :: code_ok
        call parse_csv_fields(result_header(n), names, ios)
        problem = ""
        code_ok = integer_in(fields(2)%text, -int(huge(1), int64), int(huge(1), int64), value)
        if (code_ok) code_ok = is_status_code(int(value))
        if (.not. integer_field(fields(1)%text, j)) then
            call bad(1, "an integer from " // int_str(-max_id) // " to " // int_str(max_id))
        else if (.not. code_ok) then
            call bad(2, "a holosym status code (docs/status-codes.md)")
        else if (.not. integer_in(fields(3)%text, 0_int64, int(huge(1), int64), steps)) then
            call bad(3, "an integer from 0 to " // int_str(huge(1)))
        else if (.not. integer_in(fields(4)%text, 0_int64, steps, value)) then
            call bad(4, "an integer from 0 to steps = " // int_str(int(steps)))
        else if (.not. integer_in(fields(2 * n + 8)%text, 0_int64, huge(1_int64), value)) then
            call bad(2 * n + 8, "a non-negative integer")
        end if
        if (len(problem) > 0) return
        do j = 5, 2 * n + 4
            if (.not. decimal_field(fields(j)%text, number)) then
                call bad(j, "a finite number")
                return
            end if
        end do
        do j = 2 * n + 5, 2 * n + 7
            if (decimal_field(fields(j)%text, number)) then
                if (number >= 0) cycle
            else if (any(fields(j)%text == [character(len=9) :: "NaN", "Infinity"])) then
                cycle
            end if
            call bad(j, "a number >= 0")
            return
        end do
    contains
        subroutine bad(column, what)
            integer, intent(in) :: column
            character(len=*), intent(in) :: what
            problem = "field " // int_str(column) // " (" // names(column)%text // &
                ") must be " // what // "; got '" // printable(fields(column)%text) // "'"
        end subroutine bad
    end function row_problem

    !> The lines of the text file `path` (`read_text_lines`), each without the carriage
    !! return of a CR LF line end; `ends(i)`: bytes of lines 1..i with their line ends, as
    !! in the file.
    subroutine read_lines_of(path, lines, ios, message, ends)
        character(len=*), intent(in) :: path
        type(text_line_t), allocatable, intent(out) :: lines(:)
        integer, intent(out) :: ios
        character(len=:), allocatable, intent(out) :: message
        integer(int64), allocatable, intent(out), optional :: ends(:)
        integer(int64) :: total
        integer :: i, length
        call read_text_lines(path, lines, ios, message)
        if (present(ends)) allocate (ends(size(lines)))
        total = 0
        do i = 1, size(lines)
            length = len(lines(i)%text)
            total = total + length + 1
            if (present(ends)) ends(i) = total
            if (length == 0) cycle
            if (lines(i)%text(length:length) == achar(13)) &
                lines(i)%text = lines(i)%text(:length - 1)
        end do
    end subroutine read_lines_of

    !> Append the row of a completed trajectory to the results file (closed and checked:
    !! `write_checked`); the timing log likewise; a progress line at most every
    !! `progress_interval` seconds and after the last one. A write failure, or samples
    !! that `store_samples` could not write (no row is written for that trajectory), halts
    !! the run (`finish` reports it).
    subroutine sink_completed(self, result, halt)
        class(ensemble_csv_sink), intent(inout) :: self !! the sink
        type(ensemble_result_t), intent(in) :: result   !! the completed trajectory
        logical, intent(inout) :: halt                  !! set on a write failure
        character(len=32) :: rate_text, left_text
        character(len=:), allocatable :: message
        type(text_line_t), allocatable :: row(:)
        integer(int64) :: clock_now
        real(wp) :: elapsed, rate

        if (.not. allocated(self%io_message)) self%io_message = ""
        if (.not. allocated(self%path)) self%io_message = "ensemble_csv_sink: a result " // &
            "before a successful open"
        if (len(self%io_message) > 0) then
            halt = .true.
            return
        end if
        ! Samples that could not be written are an I/O failure of the run, not of the
        ! trajectory: no row, so that --resume computes it again.
        if (result%code == HOLOSYM_INVALID_ARGUMENT .and. &
            index(result%message, samples_failure) == 1) then
            self%io_message = "trajectory " // int_str(result%id) // ": " // result%message
            halt = .true.
            return
        end if
        allocate (row(1))
        row(1)%text = result_row(result)
        call write_checked(self%path, row, "append", message)
        if (len(message) > 0) then
            self%io_message = "writing the results failed: " // message
            halt = .true.
            return
        end if
        self%rows = self%rows + 1
        self%done = self%done + 1
        if (result%code /= HOLOSYM_SUCCESS) self%failed = self%failed + 1
        if (len(self%timing_path) > 0) then
            row(1)%text = int_str(result%id) // "," // seconds_text(result%cpu_seconds) // &
                "," // seconds_text(result%wall_seconds)
            call write_checked(self%timing_path, row, "append", message)
            if (len(message) > 0) then
                self%io_message = "writing the timing log failed: " // message
                halt = .true.
                return
            end if
        end if
        if (self%progress_unit < 0) return
        call system_clock(clock_now)
        elapsed = real(clock_now - self%clock_last, wp) / self%clock_rate
        if (elapsed < self%progress_interval .and. self%done < self%to_do) return
        self%clock_last = clock_now
        elapsed = real(clock_now - self%clock_start, wp) / self%clock_rate
        rate = self%done / max(elapsed, epsilon(1.0_wp))
        rate_text = seconds_text(rate, '(f0.2)')
        left_text = seconds_text((self%to_do - self%done) / max(rate, tiny(1.0_wp)), '(f0.0)')
        write (self%progress_unit, '(a)') self%label // int_str(self%done) // "/" // &
            int_str(self%to_do) // " trajectories done (" // int_str(self%failed) // &
            " failed), " // trim(rate_text) // "/s, about " // trim(left_text) // " s left"
        flush (self%progress_unit)
    end subroutine sink_completed

    !> Seconds as text with a leading zero (microseconds, or the given format).
    function seconds_text(seconds, format) result(text)
        real(wp), intent(in) :: seconds
        character(len=*), intent(in), optional :: format
        character(len=:), allocatable :: text
        character(len=32) :: buffer
        if (present(format)) then
            write (buffer, format) seconds
        else
            write (buffer, '(f0.6)') seconds
        end if
        text = trim(buffer)
        if (len(text) >= 2) then
            if (text(len(text):) == ".") text = text(:len(text) - 1)
        end if
        if (text(1:1) == ".") text = "0" // text
        if (len(text) >= 2) then
            if (text(1:2) == "-.") text = "-0" // text(2:)
        end if
    end function seconds_text

    !> Write `samples_dir/<id>.csv` (header, then one row per sample) to a temporary file
    !! and rename it: a sample file is either complete or absent. Nothing is written when
    !! `samples_dir` is "". Fails with HOLOSYM_INVALID_ARGUMENT on an I/O error.
    subroutine sink_store_samples(self, result, status)
        class(ensemble_csv_sink), intent(in) :: self  !! the sink
        type(ensemble_result_t), intent(in) :: result !! the trajectory with its samples
        type(holosym_status_t), intent(out) :: status !! outcome
        character(len=:), allocatable :: path, temporary, line, message
        type(text_line_t), allocatable :: lines(:)
        integer :: j, i

        call set_status(status, HOLOSYM_SUCCESS, "")
        if (.not. allocated(self%samples_dir)) return
        if (len(self%samples_dir) == 0 .or. .not. allocated(result%samples)) return
        path = self%samples_dir // "/" // int_str(result%id) // ".csv"
        temporary = path // ".part"
        allocate (lines(size(result%samples, 2) + 1))
        lines(1)%text = samples_header(size(result%q))
        do j = 1, size(result%samples, 2)
            line = ""
            call append_real(line, "", result%samples(1, j))
            do i = 2, size(result%samples, 1)
                call append_real(line, ",", result%samples(i, j))
            end do
            lines(j + 1)%text = line
        end do
        call write_checked(temporary, lines, "replace", message)
        if (len(message) > 0) then
            call set_status(status, HOLOSYM_INVALID_ARGUMENT, "cannot write the samples: " // &
                message)
            return
        end if
        if (.not. rename_file(temporary, path)) call set_status(status, &
            HOLOSYM_INVALID_ARGUMENT, "cannot rename '" // temporary // "' to '" // path // "'")
    end subroutine sink_store_samples

    !> Trajectories written in this run that failed.
    integer function sink_failures(self) result(failed)
        class(ensemble_csv_sink), intent(in) :: self !! the sink
        failed = self%failed
    end function sink_failures

    !> Close the files and release the results file's lock. When the results file has a
    !! row for every trajectory, rewrite it with the rows in ascending id order (temporary
    !! file renamed over it). Fails with HOLOSYM_INVALID_ARGUMENT when a write failed
    !! during the run or now; the rows written are kept either way.
    subroutine sink_finish(self, status)
        class(ensemble_csv_sink), intent(inout) :: self !! the sink
        type(holosym_status_t), intent(out) :: status   !! outcome
        call sort_rows(self, status)
        call self%lock%release()
    end subroutine sink_finish

    !> The work of `sink_finish` before the lock is released.
    subroutine sort_rows(self, status)
        class(ensemble_csv_sink), intent(inout) :: self
        type(holosym_status_t), intent(out) :: status
        type(text_line_t), allocatable :: lines(:), fields(:)
        character(len=:), allocatable :: message, temporary
        integer, allocatable :: keys(:), order(:)
        integer :: ios, i

        call set_status(status, HOLOSYM_SUCCESS, "")
        if (.not. allocated(self%io_message)) self%io_message = ""
        if (len(self%io_message) > 0) then
            call set_status(status, HOLOSYM_INVALID_ARGUMENT, self%io_message)
            return
        end if
        if (self%rows /= self%expected_rows) return
        call read_lines_of(self%path, lines, ios, message)
        if (ios /= 0) then
            call set_status(status, HOLOSYM_INVALID_ARGUMENT, "cannot read '" // self%path // &
                "' to sort it: " // message)
            return
        end if
        allocate (keys(size(lines) - 2))
        do i = 3, size(lines)
            call parse_csv_fields(lines(i)%text, fields, ios)
            if (.not. integer_field(fields(1)%text, keys(i - 2))) keys(i - 2) = huge(1)
        end do
        order = sorted_order(keys)
        if (all(order == [(i, i = 1, size(order))])) return
        temporary = self%path // ".sort.tmp"
        call write_checked(temporary, lines([1, 2, order + 2]), "replace", message)
        if (len(message) > 0) then
            call set_status(status, HOLOSYM_INVALID_ARGUMENT, message // " (the unsorted " // &
                "rows are kept in '" // self%path // "')")
            return
        end if
        if (.not. rename_file(temporary, self%path)) call set_status(status, &
            HOLOSYM_INVALID_ARGUMENT, "cannot rename '" // temporary // "' to '" // self%path &
            // "' (the unsorted rows are kept)")
    end subroutine sort_rows

end module holosym_ensemble_files
