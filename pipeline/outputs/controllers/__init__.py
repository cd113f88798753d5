"""Controller programs in the makers' own languages: writers (``rapid``, ``fanuc_ls``, ``yaskawa_jbi``, ``krl``,
``urscript``), readers of the same (``read_*``, on the lark grammars in ``grammars/``) and ``lint``. The makers'
conventions these programs use (axis angles, configuration data) are part of the model: ``pipeline.model.vendors``."""
