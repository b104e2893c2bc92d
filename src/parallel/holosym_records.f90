!> Records hold the results of a farmed task as a string of bytes, so that every farm (threads
!! or MPI ranks) moves them the same way. Values are appended with `put` and read back in
!! the same order with `get`; the bytes are the values' memory images (exact: a real comes
!! back bit for bit), valid between processes of the same executable.
module holosym_records
    use, intrinsic :: iso_fortran_env, only: int64
    use holosym_kinds, only: wp
    implicit none
    private

    public :: record_reader_t, put

    !> Append a value to a record.
    interface put
        module procedure put_integer, put_integer64, put_real, put_reals, put_text, put_logical
    end interface put

    !> Reads the values of a record in the order they were put.
    type :: record_reader_t
        !> Position of the next byte.
        integer :: position = 1
        !> True once a read went past the end (the values read then are zero or blank).
        logical :: overrun = .false.
    contains
        procedure :: integer => get_integer
        procedure :: integer64 => get_integer64
        procedure :: real => get_real
        procedure :: reals => get_reals
        procedure :: text => get_text
        procedure :: logical => get_logical
    end type record_reader_t

contains

    !> Append an integer.
    pure subroutine put_integer(record, value)
        character(len=:), allocatable, intent(inout) :: record !! the record
        integer, intent(in) :: value !! the value
        character(len=storage_size(value) / 8) :: bytes
        if (.not. allocated(record)) record = ""
        bytes = transfer(value, bytes)
        record = record // bytes
    end subroutine put_integer

    !> Append a 64-bit integer.
    pure subroutine put_integer64(record, value)
        character(len=:), allocatable, intent(inout) :: record !! the record
        integer(int64), intent(in) :: value !! the value
        character(len=storage_size(value) / 8) :: bytes
        if (.not. allocated(record)) record = ""
        bytes = transfer(value, bytes)
        record = record // bytes
    end subroutine put_integer64

    !> Append a logical.
    pure subroutine put_logical(record, value)
        character(len=:), allocatable, intent(inout) :: record !! the record
        logical, intent(in) :: value !! the value
        call put_integer(record, merge(1, 0, value))
    end subroutine put_logical

    !> Append a real.
    pure subroutine put_real(record, value)
        character(len=:), allocatable, intent(inout) :: record !! the record
        real(wp), intent(in) :: value !! the value
        character(len=storage_size(value) / 8) :: bytes
        if (.not. allocated(record)) record = ""
        bytes = transfer(value, bytes)
        record = record // bytes
    end subroutine put_real

    !> Append an array of reals, preceded by its size.
    pure subroutine put_reals(record, values)
        character(len=:), allocatable, intent(inout) :: record !! the record
        real(wp), intent(in) :: values(:) !! the values
        character(len=storage_size(values) / 8 * size(values)) :: bytes
        call put_integer(record, size(values))
        if (size(values) == 0) return
        bytes = transfer(values, bytes)
        record = record // bytes
    end subroutine put_reals

    !> Append a text, preceded by its length.
    pure subroutine put_text(record, text)
        character(len=:), allocatable, intent(inout) :: record !! the record
        character(len=*), intent(in) :: text !! the text
        call put_integer(record, len(text))
        record = record // text
    end subroutine put_text

    !> The next `length` bytes, or an overrun.
    subroutine take(self, record, length, first, last)
        class(record_reader_t), intent(inout) :: self
        character(len=*), intent(in) :: record
        integer, intent(in) :: length
        integer, intent(out) :: first, last
        first = self%position
        last = first + length - 1
        if (length < 0 .or. last > len(record)) then
            self%overrun = .true.
            first = 1
            last = 0
            return
        end if
        self%position = last + 1
    end subroutine take

    !> Read an integer (0 after an overrun).
    integer function get_integer(self, record) result(value)
        class(record_reader_t), intent(inout) :: self !! the reader
        character(len=*), intent(in) :: record        !! the record
        integer :: first, last
        value = 0
        call take(self, record, storage_size(value) / 8, first, last)
        if (last >= first) value = transfer(record(first:last), value)
    end function get_integer

    !> Read a 64-bit integer (0 after an overrun).
    integer(int64) function get_integer64(self, record) result(value)
        class(record_reader_t), intent(inout) :: self !! the reader
        character(len=*), intent(in) :: record        !! the record
        integer :: first, last
        value = 0
        call take(self, record, storage_size(value) / 8, first, last)
        if (last >= first) value = transfer(record(first:last), value)
    end function get_integer64

    !> Read a logical.
    logical function get_logical(self, record) result(value)
        class(record_reader_t), intent(inout) :: self !! the reader
        character(len=*), intent(in) :: record        !! the record
        value = get_integer(self, record) /= 0
    end function get_logical

    !> Read a real (0 after an overrun).
    real(wp) function get_real(self, record) result(value)
        class(record_reader_t), intent(inout) :: self !! the reader
        character(len=*), intent(in) :: record        !! the record
        integer :: first, last
        value = 0
        call take(self, record, storage_size(value) / 8, first, last)
        if (last >= first) value = transfer(record(first:last), value)
    end function get_real

    !> Read an array of reals put by `put`.
    function get_reals(self, record) result(values)
        class(record_reader_t), intent(inout) :: self !! the reader
        character(len=*), intent(in) :: record        !! the record
        real(wp), allocatable :: values(:)
        integer :: count, first, last
        count = get_integer(self, record)
        allocate (values(max(count, 0)))
        if (count <= 0) return
        values = 0
        call take(self, record, storage_size(values) / 8 * count, first, last)
        if (last >= first) values = transfer(record(first:last), values, count)
    end function get_reals

    !> Read a text put by `put`.
    function get_text(self, record) result(text)
        class(record_reader_t), intent(inout) :: self !! the reader
        character(len=*), intent(in) :: record        !! the record
        character(len=:), allocatable :: text
        integer :: length, first, last
        length = get_integer(self, record)
        call take(self, record, max(length, 0), first, last)
        text = record(first:last)
    end function get_text

end module holosym_records
