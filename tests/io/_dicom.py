"""A DICOM series written by pydicom (the format's own library), for the volume reader tests."""
import numpy as np
import pytest

__all__ = ["dicom_series"]


def dicom_series(folder, a, spacing=(0.7, 0.8), dz=2.5, origin=(-10.0, 5.0, 100.0), *, shuffle=True,
                 intercept=-1024):
    """Write ``a`` (z, y, x) as a CT series with pydicom, one file per slice, file names shuffled (``shuffle``)
    so a reader must sort by ``ImagePositionPatient``; ``intercept`` None writes no rescale tags."""
    pydicom = pytest.importorskip("pydicom")
    from pydicom.dataset import FileDataset, FileMetaDataset
    from pydicom.uid import ExplicitVRLittleEndian, generate_uid
    series = generate_uid()
    order = np.random.default_rng(3).permutation(len(a)) if shuffle else np.arange(len(a))
    for n, k in enumerate(order):                             # file names not in slice order
        meta = FileMetaDataset()
        meta.MediaStorageSOPClassUID = pydicom.uid.CTImageStorage
        meta.MediaStorageSOPInstanceUID = generate_uid()
        meta.TransferSyntaxUID = ExplicitVRLittleEndian
        ds = FileDataset(str(folder / f"IM{n:04d}.dcm"), {}, file_meta=meta, preamble=b"\0" * 128)
        ds.SOPClassUID, ds.SOPInstanceUID = meta.MediaStorageSOPClassUID, meta.MediaStorageSOPInstanceUID
        ds.SeriesInstanceUID, ds.Modality = series, "CT"
        ds.Rows, ds.Columns = a.shape[1:]
        ds.SamplesPerPixel, ds.PhotometricInterpretation = 1, "MONOCHROME2"
        ds.BitsAllocated = ds.BitsStored = a.dtype.itemsize * 8
        ds.HighBit = ds.BitsStored - 1
        ds.PixelRepresentation = int(a.dtype.kind == "i")
        ds.PixelSpacing = list(spacing)
        ds.ImageOrientationPatient = [1, 0, 0, 0, 1, 0]
        ds.ImagePositionPatient = [origin[0], origin[1], origin[2] + k * dz]
        if intercept is not None:
            ds.RescaleSlope, ds.RescaleIntercept = 1, intercept
        ds.PixelData = np.ascontiguousarray(a[k]).tobytes()
        ds.save_as(str(folder / f"IM{n:04d}.dcm"), enforce_file_format=True)
